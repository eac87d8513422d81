"""``mitnerf fit``: train a field on any dataset mitnerf reads."""

from __future__ import annotations

import argparse
import json

from ..errors import MitnerfError


def parse_background(text: str | None, default):
    if text is None:
        return tuple(default)
    named = {"black": (0.0, 0.0, 0.0), "white": (1.0, 1.0, 1.0)}
    if text in named:
        return named[text]
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 3:
        raise MitnerfError(f"--background must be black, white or r,g,b (three numbers), got {text!r}")
    return vals


def parse_sets(items: list[str]) -> dict:
    """``key=value`` pairs; values are JSON literals when they parse, else strings."""
    out = {}
    for item in items or []:
        if "=" not in item:
            raise MitnerfError(f"--set expects key=value, got {item!r}")
        k, v = item.split("=", 1)
        try:
            out[k.strip()] = json.loads(v)
        except json.JSONDecodeError:
            out[k.strip()] = v
    return out


def add_model_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("model")
    g.add_argument("--field", default="vanilla", help="field family")
    g.add_argument("--width", type=int, default=None)
    g.add_argument("--depth", type=int, default=None)
    g.add_argument("--pos-L", type=int, default=None, help="positional-encoding frequencies")
    g.add_argument("--dir-L", type=int, default=None, help="view-direction encoding frequencies")
    g.add_argument("--no-view-dependence", action="store_true")
    g.add_argument("--density-activation", choices=["relu", "softplus", "trunc_exp"], default=None)
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any other argument of the field's config (repeatable)")
    g.add_argument("--samples", type=int, default=64, help="coarse samples per ray")
    g.add_argument("--fine", type=int, default=0, help="importance samples per ray (0: no fine pass)")
    g.add_argument("--background", default=None, help="black, white or r,g,b (default: the dataset's)")
    g.add_argument("--method", choices=["replay", "autodiff"], default="replay", help="volume integral")


def model_config(args, dataset):
    from ..render.pipeline import RenderConfig
    from ..train.config import ModelConfig

    field_args = parse_sets(args.set)
    for key, value in (("width", args.width), ("depth", args.depth), ("pos_L", args.pos_L),
                       ("dir_L", args.dir_L), ("density_activation", args.density_activation)):
        if value is not None:
            field_args[key] = value
    if args.no_view_dependence:
        field_args["view_dependent"] = False
    render = RenderConfig(n_coarse=args.samples, n_fine=args.fine, method=args.method,
                          background=parse_background(args.background, dataset.background))
    return ModelConfig(args.field, field_args, render)


def register(sub) -> None:
    p = sub.add_parser("fit", help="train a field on a dataset", formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--data", required=True, help="dataset folder (NeRF2D, Blender/nerfstudio) or tiny-NeRF .npz")
    p.add_argument("--backend", choices=["drjit", "torch"], default="drjit")
    p.add_argument("--iters", type=int, default=2000)
    p.add_argument("--time-budget", type=float, default=None, help="seconds of training")
    p.add_argument("--out", default=None, help="folder for the checkpoint, metrics and figures")
    p.add_argument("--lr", type=float, default=5e-3)
    p.add_argument("--lr-final", type=float, default=5e-4)
    p.add_argument("--batch", type=int, default=1024, help="rays per step")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--val-every", type=int, default=250)
    g = p.add_argument_group("auto-sizing (--auto)")
    g.add_argument("--auto", action="store_true",
                   help="search for the smallest model that reaches --target validation PSNR, then train it")
    g.add_argument("--target", type=float, default=30.0, help="validation PSNR to reach (dB)")
    g.add_argument("--auto-steps", type=int, default=400, help="training steps per candidate")
    g.add_argument("--auto-budget", type=float, default=300.0, help="seconds for the whole search")
    add_model_args(p)
    p.set_defaults(run=run_fit)


def run_fit(args) -> int:
    from ..data.formats import load_dataset
    from ..train.config import TrainConfig
    from ..train.report import fit_and_report, summary_line
    from ..train.trainer import TrainingFailed

    if args.iters < 1:
        raise MitnerfError(f"--iters must be at least 1, got {args.iters}")
    ds = load_dataset(args.data)
    mc = model_config(args, ds)
    tc = TrainConfig(iters=args.iters, time_budget=args.time_budget, batch_rays=args.batch, lr=args.lr,
                     lr_final=args.lr_final, seed=args.seed, val_every=args.val_every)
    if args.auto:
        from ..train.auto import AutoConfig, auto_size

        result = auto_size(ds, AutoConfig(target_psnr=args.target, steps=args.auto_steps,
                                          time_budget=args.auto_budget, seed=args.seed, batch_rays=args.batch))
        print(result.table())
        for reason in result.reasons:
            print(f"- {reason}")
        mc = result.model
        tc.lr, tc.lr_final = result.train.lr, result.train.lr_final
    try:
        from ..fields import field_config

        field_config(mc.field, **{**mc.field_args, "dim": ds.dim})
    except TypeError as exc:
        raise MitnerfError(f"bad field argument for {mc.field!r}: {exc}; see the field's config") from None
    try:
        _, metrics = fit_and_report(ds, mc, tc, args.backend, args.out)
    except TrainingFailed as exc:
        print(f"mitnerf: training stopped: {exc}")
        return 1
    if args.out:
        print(f"wrote {args.out}")
    print(summary_line(metrics, args.backend, mc.field))
    return 0
