"""``mitnerf experiment NAME --out DIR [--quick] [--seed S]``."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    from ..experiments import EXPERIMENTS

    p = sub.add_parser("experiment", help="run an experiment; writes CSV, figures and report.md")
    p.add_argument("name", choices=list(EXPERIMENTS))
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--quick", action="store_true", help="a small version (about 2 minutes)")
    p.add_argument("--full", action="store_true",
                   help="the complete design where an experiment has one (window-shop: the whole factorial)")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(run=run_experiment)


def run_experiment(args) -> int:
    from ..experiments import get_experiment

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import inspect

    from ..errors import MitnerfError

    run = get_experiment(args.name).run
    extra = {}
    if args.full:
        if "full" not in inspect.signature(run).parameters:
            raise MitnerfError(f"experiment {args.name!r} has no --full design; drop --full")
        if args.quick:
            raise MitnerfError("--full and --quick exclude each other; drop one")
        extra["full"] = True
    report = run(out, quick=args.quick, seed=args.seed, **extra)
    print(f"wrote {report}")
    return 0


def example_main(name: str, doc: str, argv=None) -> int:
    """What an ``examples/`` script of an experiment runs: ``mitnerf experiment <name>``
    with ``--out`` defaulting to ``out/experiments/<name>``."""
    import argparse

    from . import main as cli

    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=f"out/experiments/{name}")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    return cli(["experiment", name, "--out", a.out, "--seed", str(a.seed)] + (["--quick"] if a.quick else []))
