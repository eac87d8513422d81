"""Fit the 2D bunny: NeRF2D's protocol (50 training views of 100 px), on 2 cores.

Renders (or reuses a cached copy of) the bunny dataset, trains the chosen field with
its preset (default: the dense grid for 10 seconds), and writes under ``--out``: the test views beside ground truth, the depth
strip, the density field, the loss/PSNR curves, the checkpoint and metrics.

    python examples/fit_bunny.py [--field F] [--backend drjit|torch] [--iters N] [--time-budget S]

Last line: ``test PSNR <x> dB, train <t> s, <backend> <field>``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mitnerf  # noqa: F401
from mitnerf.data.formats import load_dataset, save_dataset
from mitnerf.train.presets import preset, preset_fields
from mitnerf.train.report import fit_and_report, summary_line

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FIELD = "grid"
DEFAULT_BUDGET = {"grid": 10.0}     # seconds of training; other fields run their preset's steps


def bunny_dataset(folder: Path):
    """The NeRF2D-protocol bunny: 50 random noisy train views, 10 val, 20 test, 100 px."""
    if (folder / "train" / "transforms.json").exists():
        return load_dataset(folder)
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig, noise_preset
    from mitnerf.scenes.registry import get_scene

    ds = make_dataset(get_scene("bunny"), RigConfig(dim=2, n_train=50, n_val=10, n_test=20, resolution=100,
                                                    seed=0, **noise_preset(1.0)))
    save_dataset(ds, folder)
    return load_dataset(folder)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--field", choices=preset_fields(), default=DEFAULT_FIELD)
    p.add_argument("--backend", choices=["drjit", "torch"], default="drjit")
    p.add_argument("--iters", type=int, default=None, help="steps (default: the preset's)")
    p.add_argument("--time-budget", type=float, default=None, help="seconds of training (default: the preset's)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--data", default=str(ROOT / "out" / "datasets" / "bunny"))
    p.add_argument("--out", default=None, help="default: out/fit_bunny/<field>-<backend>")
    args = p.parse_args(argv)

    ds = bunny_dataset(Path(args.data))
    model_cfg, train_cfg = preset(args.field, 2)
    train_cfg.seed = args.seed
    if args.iters is not None:
        train_cfg.iters = args.iters
    budget = args.time_budget if args.time_budget is not None else DEFAULT_BUDGET.get(args.field)
    if budget is not None and args.iters is None:
        train_cfg.time_budget, train_cfg.iters = budget, 100_000
    elif budget is not None:
        train_cfg.time_budget = budget
    out = Path(args.out or ROOT / "out" / "fit_bunny" / f"{args.field}-{args.backend}")
    _, metrics = fit_and_report(ds, model_cfg, train_cfg, args.backend, out)
    print(f"wrote {out}: test_views.png, test_depth.png, density.png, curves.png")
    print(summary_line(metrics, args.backend, args.field))
    return 0


if __name__ == "__main__":
    sys.exit(main())
