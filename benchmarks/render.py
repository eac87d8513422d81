"""Rendering a trained field: the colour deferred (:mod:`mitnerf.render.deferred`, the default) against the fused
march (``--set defer_color=false``), on the lego's 200 test views.

The field is part ``3600``'s of ``benchmarks/lego.py`` (``out/lego/3600``, the hour's) where it exists, else the one
this benchmark fits with the plain command line for ``--budget`` seconds (``out/lego/render``, kept for later
runs). Each measurement is its own process: it loads the checkpoint, evaluates the 200 test views with
``defer_color`` on or off (the order alternating over ``--repeats``), and reports the seconds spent rendering, the
PSNR and the process's peak memory. Sizes: the test views at 400 x 400, and (``800``) the same views upsampled twice
(nearest, into a temporary folder; the cameras of the held-back 800 x 800 views): four times the rays, the size whose
two-minute limit the lego goals set. Records
``render/lego`` in ``results.json``: per size, the median seconds of each, their ratio, both PSNRs (the same renders:
they differ by rounding) and both peaks. Where the data is absent, one line says so and nothing runs.

    python benchmarks/render.py [--data ../shared/data/nerf_synthetic/lego_400] [--sizes 400 800] [--budget 300]
                                [--repeats 2]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

if __package__:                        # imported as benchmarks.render (the tests)
    from ._cli import ROOT, alternating, child, medians, mitnerf
    from .lego import DATA, RUN_3600, upsampled
else:                                  # run as python benchmarks/render.py
    from _cli import ROOT, alternating, child, medians, mitnerf
    from lego import DATA, RUN_3600, upsampled

COMMAND = "python benchmarks/render.py"
MODES = ("fused", "deferred")

CHILD = r"""
import json, sys
import drjit as dr
from mitnerf.data.formats import load_dataset
from mitnerf.train.checkpoint import load_checkpoint
from mitnerf.train.evaluate import evaluate, peak_memory

run, _ = load_checkpoint(sys.argv[1])
run.backend.model_cfg.render.defer_color = sys.argv[3] == "deferred"
dr.set_thread_count(2)
rec = evaluate(run.backend, load_dataset(sys.argv[2]), "test", geometry_metrics=False)
print(json.dumps({"render_s": rec.render_time * rec.views, "psnr": rec.psnr, "views": rec.views,
                  "peak_gib": peak_memory()}))
"""


def measure(run: Path, data: Path, mode: str) -> dict:
    return child(CHILD, run.resolve(), data.resolve(), mode)


def field(data: Path, budget: str) -> tuple[Path, str]:
    """The checkpoint to render, and how it was made."""
    if (RUN_3600 / "metrics.json").is_file():
        return RUN_3600, "part 3600's field of benchmarks/lego.py (the hour's)"
    out = ROOT / "out" / "lego" / "render"
    if (out / "metrics.json").is_file():
        return out, f"a field fitted for {json.loads((out / 'metrics.json').read_text())['train_time']:.0f} s " \
                    "(mitnerf fit --data <lego_400>; out/lego/render, fitted by an earlier run)"
    mitnerf("fit", "--data", str(data), "--time-budget", budget, "--test-views", "1", "--no-figures", "--out",
            str(out))
    return out, f"a field fitted for {budget} s (mitnerf fit --data <lego_400> --time-budget {budget})"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=DATA, help="the lego_400 folder")
    p.add_argument("--sizes", nargs="+", choices=("400", "800"), default=["400", "800"])
    p.add_argument("--budget", default="300", help="seconds of training where part 3600's field is absent")
    p.add_argument("--repeats", type=int, default=2)
    args = p.parse_args(argv)
    if not (args.data / "transforms_train.json").is_file():
        print(f"render: skipped, no Blender lego at {args.data} (see ../shared/data/README.md)")
        return 0
    from mitnerf.results import record_result

    run, made = field(args.data, args.budget)
    values, lines = {"field": made, "repeats": args.repeats}, []
    with tempfile.TemporaryDirectory() as tmp:
        for size in args.sizes:
            data = args.data if size == "400" else upsampled(args.data, Path(tmp))
            runs = alternating(MODES, args.repeats, lambda mode: measure(run, data, mode))
            v = medians(runs, ("render_s", "psnr", "peak_gib"))
            v.update(views=runs["deferred"][0]["views"], ratio=v["fused_render_s"] / v["deferred_render_s"])
            values[size] = v
            lines.append(f"{size} x {size}: the 200 test views rendered in {v['deferred_render_s']:.1f} s deferred, "
                         f"{v['fused_render_s']:.1f} s fused ({v['ratio']:.2f}x); PSNR {v['deferred_psnr']:.3f} "
                         f"against {v['fused_psnr']:.3f} dB; peak {v['deferred_peak_gib']:.2f} against "
                         f"{v['fused_peak_gib']:.2f} GiB")
            print(lines[-1], flush=True)
    record_result("render/lego", values, f"{made}: " + "; ".join(lines), COMMAND, threads=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
