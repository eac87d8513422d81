"""Real captures fitted as a user fits them: ``mitnerf fit --data DIR --time-budget T`` (the default recipe, the scene
chosen from the data) on LLFF's fern at 504 x 378 (``--downscale 8``: its ``images_8/`` folder) and on instant-ngp's
fox as shipped (its lens distortion, its absent frames skipped), every 8th view held out for test, then ``mitnerf
video`` of the fox along its capture's path. Records test PSNR and SSIM, steps, the scene and recipe, the load
average before and after each fit (the machine may be shared), with the command and machine, in ``results.json``
(``fern/fit``, ``fox/fit``); a capture whose folder is absent is skipped with one line.

    python benchmarks/captures.py [--time-budget 600] [--only fern fox] [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

from mitnerf.results import record_result
from mitnerf.train.checkpoint import read_manifest
from mitnerf.train.config import TrainConfig

if __package__:                        # imported as benchmarks.captures (the tests)
    from ._cli import ROOT, mitnerf, said
else:                                  # run as python benchmarks/captures.py
    from _cli import ROOT, mitnerf, said

CAPTURES = {"fern": ("llff/fern", ["--downscale", "8"]), "fox": ("instant_ngp/fox", [])}
"""Each capture's folder under the data folder, and the flags that select its views."""
ANCHORS = {"fern": [("NeRF", "25.17", "about a day", "GPU", "1008 x 756"),
                    ("Plenoxels", "25.46", "", "GPU", "1008 x 756")]}
"""Published test PSNR on LLFF's protocol (every 8th view held out): (method, dB, training, GPU, views' size)."""


def fit(name: str, data: Path, budget: float, out: Path) -> dict:
    """Fit one capture with the CLI in a fresh process; its figures, printed lines and command."""
    folder, flags = CAPTURES[name]
    args = ["fit", "--data", str(data / folder), *flags, "--time-budget", f"{budget:g}", "--out", str(out / name),
            "--no-progress"]
    load = os.getloadavg()[0]
    lines, wall = mitnerf(*args)
    manifest = read_manifest(out / name)
    metrics, (w, h) = manifest["metrics"], manifest["dataset"]["size"]
    values = {"size": f"{w} x {h}", "psnr": metrics["psnr"], "ssim": metrics["ssim"],
              "train_s": metrics["train_time"], "steps": metrics["steps"], "wall_s": wall, "load_before": load,
              "load_after": os.getloadavg()[0],
              "scene": said(lines, "scene: "), "recipe": re.sub(r"^recipe (\S+):.*", r"\1", said(lines, "recipe "))}
    shown = " ".join(["python -m mitnerf", *(a.replace(str(data), "DATA") for a in args[:-3])])
    return {"values": values, "last": lines[-1], "command": shown}


def video(out: Path) -> str:
    """``mitnerf video`` of the fitted fox along its capture's path; its last line."""
    lines, _ = mitnerf("video", "--checkpoint", out / "fox", "--out", out / "fox-video", "--image-size", "270")
    return lines[-1] if lines else "?"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--time-budget", type=float, default=600.0, help="seconds of training per capture (default 600)")
    p.add_argument("--only", nargs="+", choices=list(CAPTURES), default=list(CAPTURES))
    p.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    p.add_argument("--out", type=Path, default=None, help="where the runs go (default: a temporary folder)")
    args = p.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="captures-"))
    for name in args.only:
        if not (args.data / CAPTURES[name][0]).is_dir():
            print(f"{name}: skipped, {args.data / CAPTURES[name][0]} is absent")
            continue
        run = fit(name, args.data, args.time_budget, out)
        v = run["values"]
        extra = f"; {video(out)}" if name == "fox" else ""
        summary = (f"{name}: {run['last']} ({v['size']} pixels, {v['steps']} steps; {v['scene']}; load "
                   f"{v['load_before']:.1f} -> {v['load_after']:.1f}){extra}")
        print(summary)
        record_result(f"{name}/fit", v, summary, run["command"], recipe=v["recipe"], threads=TrainConfig().threads)
    return 0


if __name__ == "__main__":
    sys.exit(main())
