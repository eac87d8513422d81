"""The README's first steps, as written: every command succeeds, and each one that computes something leaves its
result on disk and says where; no picture they write is over 4096 pixels on its longer side."""

from __future__ import annotations

import os
import re
import shlex

import pytest
from conftest import ROOT

from mitnerf.cli import main

pytestmark = pytest.mark.slow


def first_steps() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = text.split("## First steps", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    return [line.split("#", 1)[0].strip() for line in block.splitlines() if line.startswith("mitnerf ")]


def test_the_readme_lists_its_first_steps():
    steps = first_steps()
    assert len(steps) >= 8 and all(s.startswith("mitnerf ") for s in steps)
    assert {s.split()[1] for s in steps} >= {"dataset", "show", "fit", "compare", "recipes", "video"}


def test_every_first_step_runs_as_written_and_says_where_its_result_is(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    for step in first_steps():
        assert main(shlex.split(step)[1:]) == 0, step
        out = capsys.readouterr().out
        if step.split()[1] == "recipes":
            assert "the default" in out
            continue
        said = re.findall(r"(?:wrote|writing to) (\S+)", out) + [ln for ln in out.splitlines() if ln.startswith("/")]
        assert said, f"{step} did not say where it wrote: {out[-300:]}"
        for path in said:
            where = path.rstrip(":;,")
            assert os.path.exists(where), (step, where)
    import imageio.v3 as iio

    pngs = list(tmp_path.rglob("*.png"))
    assert len(pngs) >= 8
    for png in pngs:                                 # every picture the commands wrote is one a person opens
        assert max(iio.improps(png).shape[:2]) <= 4096, png
