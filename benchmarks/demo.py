"""The README's demo and the same run through `mitnerf fit`, measured as a user sees them.

Runs ``python examples/fit_bunny.py`` (the demo: the bunny dataset, then `mitnerf fit` with
the default recipe) and ``mitnerf fit --data <that dataset> --time-budget 10`` in fresh
processes, checks that they print the same recipe, and records their last lines (test PSNR,
SSIM, IoU, train time) and wall times in ``results.json`` (``demo/bunny``, ``fit/bunny-cli``).

    python benchmarks/demo.py
"""

from __future__ import annotations

import re
import sys

from mitnerf.results import record_result
from mitnerf.train.config import TrainConfig

if __package__:                        # imported as benchmarks.demo (the tests)
    from ._cli import ROOT, run, said
else:                                  # run as python benchmarks/demo.py
    from _cli import ROOT, run, said

DATA = ROOT / "out" / "datasets" / "bunny"


def first_last(cmd: list[str]) -> tuple[str, str, float]:
    """``cmd``'s recipe line, its last line and its seconds."""
    lines, wall = run(cmd)
    return said(lines, "recipe "), lines[-1], wall


def main() -> int:
    results = {}
    for key, cmd in (("demo/bunny", [sys.executable, "examples/fit_bunny.py"]),
                     ("fit/bunny-cli", [sys.executable, "-m", "mitnerf", "fit", "--data", str(DATA), "--time-budget",
                                        "10", "--out", str(ROOT / "out" / "fit_bunny_cli")])):
        first, last, wall = first_last(cmd)
        recipe = first[len("recipe "):] if first.startswith("recipe ") else "?"
        psnr = float(re.search(r"test PSNR ([\d.]+) dB", last).group(1))
        values = {"psnr": psnr, "wall_s": wall, "recipe": recipe.split(":")[0]}
        for name, pattern in (("ssim", r"SSIM ([\d.]+)"), ("iou", r"IoU ([\d.]+)"), ("train_s", r"train ([\d.]+) s")):
            m = re.search(pattern, last)
            if m:
                values[name] = float(m.group(1))
        results[key] = (values, recipe)
        print(f"{key}: {last} ({wall:.1f} s wall)\n    {first}")
        record_result(key, values, f"{last} ({wall:.1f} s wall with start-up)", " ".join(
            c if c != sys.executable else "python" for c in cmd).replace(str(ROOT) + "/", ""),
                      recipe=values["recipe"], threads=TrainConfig().threads)     # the recipes' own
    same = results["demo/bunny"][1].replace("+", "") == results["fit/bunny-cli"][1].replace("+", "")
    gap = abs(results["demo/bunny"][0]["psnr"] - results["fit/bunny-cli"][0]["psnr"])
    print(f"same recipe: {same}; PSNR gap {gap:.2f} dB")
    return 0 if same and gap <= 0.5 else 1


if __name__ == "__main__":
    sys.exit(main())
