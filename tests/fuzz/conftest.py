"""Hostile inputs, generated (Hypothesis): every bad input to the command line ends in ONE
line on stderr that starts with ``mitnerf: error:``, exit status 2, no traceback, and
nothing written (no output folder, no temporary leftovers, the inputs untouched).

Each case starts from a VALID tiny input written by mitnerf's own writers (datasets in
every format mitnerf reads, polygons, Mitsuba XML, checkpoints, command lines) and breaks
exactly one thing, chosen by Hypothesis; a breakage is built so that it can never be
accidentally valid (a valid case would train and write, and fail the test). Everything
goes through the real entry point, ``mitnerf.cli.main``, in-process; a few cases run
``python -m mitnerf`` in a subprocess to see the real stderr.

Profiles (``tests/conftest.py``): ``HYPOTHESIS_PROFILE=ci`` (default: derandomized, a
fixed number of examples, well under a minute) or ``local`` (many more examples). The
number of distinct cases tried is printed at the end of the pytest run; ``FUZZ_TRACE=1``
(with ``pytest -s``) prints every case and the line it ended in.

This file: the valid inputs (written once per session: the real-capture formats too) and the case counts; the rule and
the inputs' writers are in ``harness.py``, the bad values and damages in ``strategies.py``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from mitnerf.data.formats import save_dataset
from mitnerf.data.formats.colmap import write_colmap

from .harness import CASES, Inputs, run_main, write_addon, write_ngp


@pytest.fixture(scope="session")
def base():
    """Valid inputs, written once: datasets in every format, polygons, XML, checkpoints."""
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.scenes.gt_render import RenderSettings
    from mitnerf.scenes.ply import write_ply
    from mitnerf.scenes.registry import get_scene

    with tempfile.TemporaryDirectory(prefix="fuzz-base-") as t:
        root = Path(t)
        d2 = make_dataset(get_scene("square"), RigConfig(dim=2, n_train=3, n_val=2, n_test=2, resolution=16, seed=1),
                          RenderSettings(spp=4), progress=False)
        d3 = make_dataset(get_scene("vase"), RigConfig(dim=3, n_train=3, n_val=1, n_test=2, resolution=8, seed=1),
                          RenderSettings(spp=4), progress=False)
        p = Inputs(d2=d2, d3=d3, root=root)
        for name, ds, fmt in [("nerf2d", d2, "nerf2d"), ("blender", d3, "blender"), ("nerfstudio3", d3, "nerfstudio"),
                              ("nerfstudio2", d2, "nerfstudio"), ("llff", d3, "llff"), ("colmap", d3, "colmap"),
                              ("idr", d3, "idr")]:
            p[name] = save_dataset(ds, root / name, fmt)
        (root / "colmap_bin").mkdir()
        write_colmap(d3, root / "colmap_bin", binary=True)
        p["colmap_bin"] = root / "colmap_bin"
        write_addon(d2, root / "addon")
        p["addon"] = root / "addon"
        write_ngp(root / "blender", root / "ngp")
        p["ngp"] = root / "ngp"
        p["tiny"] = save_dataset(d3, root / "tiny.npz", "tiny_nerf")
        v, f, _ = get_scene("square").polygon.prism()
        write_ply(root / "mesh.ply", v, f)
        p["ply"] = root / "mesh.ply"
        small = ["--iters", "2", "--field", "vanilla", "--mlp-width", "8", "--mlp-depth", "2", "--samples", "8", "--fine", "0",
                 "--pos-L", "2", "--dir-L", "1", "--batch", "64", "--no-figures"]
        for name, data in (("ckpt3", "blender"), ("ckpt2", "nerf2d")):
            rc, out, err, _ = run_main(["fit", "--data", p[data], "--out", root / name, *small])
            assert rc == 0, err
            p[name] = root / name
        yield p


@pytest.fixture(scope="session", autouse=True)
def report(request):
    yield
    n = sum(len(v) for v in CASES.values())
    lines = [f"fuzz: {n} distinct hostile cases, all ended in one line, exit 2, nothing written"]
    lines += [f"  {len(v):5d}  {k}" for k, v in sorted(CASES.items())]
    request.config.mitnerf_summary = getattr(request.config, "mitnerf_summary", []) + lines
