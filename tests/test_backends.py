"""Both backends agree: examples/check_backends.py (same weights, rays and random cotangents
through every Dr.Jit variant, the native MLP included, and the torch twin; then finite
differences) on small cases of every field in 2D and 3D."""

import importlib.util
from pathlib import Path

import pytest

from mitnerf.fields.native import library

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "check_backends.py"


def check_backends():
    spec = importlib.util.spec_from_file_location("check_backends", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("field", ["vanilla", "grid", "hashgrid"])
def test_check_backends_passes(field, dim, capsys):
    mod = check_backends()
    if field == "vanilla" and library() is None:
        mod.VARIANTS["vanilla"] = [v for v in mod.VARIANTS["vanilla"] if v[1] != "native"]
    rc = mod.main(["--field", field, "--dim", str(dim), "--rays", "24", "--samples", "16", "--fine", "8"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "native MLP" in out or field != "vanilla" or library() is None
