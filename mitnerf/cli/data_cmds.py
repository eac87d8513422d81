"""``mitnerf dataset`` (render a dataset) and ``mitnerf show`` (its pictures)."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("dataset", help="render a dataset of a scene",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--scene", default=None, help="scene name, or a path to a Mitsuba XML file")
    p.add_argument("--polygon", default=None, help="JSON file with a closed ring of [x, y] points (a 2D scene)")
    p.add_argument("--out", required=True, help="output folder (written atomically)")
    p.add_argument("--views", type=int, default=50, help="training views")
    p.add_argument("--val", type=int, default=10, help="validation views")
    p.add_argument("--test", type=int, default=20, help="test views (evenly spaced, noise-free)")
    p.add_argument("--resolution", type=int, default=100, help="pixels (per side in 3D)")
    p.add_argument("--radius", type=float, default=None, help="camera distance (default 4 in 2D, 3.5 in 3D)")
    p.add_argument("--fov", type=float, default=None, help="field of view in degrees")
    p.add_argument("--layout", choices=["random", "even"], default="random", help="train/val placement")
    p.add_argument("--noise", type=float, default=1.0,
                   help="scale of all placement noise (1: radius 0.1, angle 2 deg, position 0.05, look 1 deg)")
    for name in ("radius-std", "angle-std", "position-std", "look-std"):
        p.add_argument(f"--{name}", type=float, default=None, help="override one noise parameter")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel for colour")
    p.add_argument("--seed", type=int, default=0, help="seed of placement noise and of the renderer")
    p.add_argument("--format", choices=["nerf2d", "blender", "tiny_nerf"], default=None,
                   help="file format (default: nerf2d for 2D, blender for 3D)")
    p.add_argument("--kind", choices=["2d", "3d"], default=None, help="kind of a scene given as XML")
    p.set_defaults(run=run_dataset)

    s = sub.add_parser("show", help="write the views strip, depth strip and rig plot of a dataset")
    s.add_argument("dataset", help="dataset folder (or tiny-NeRF .npz)")
    s.add_argument("--out", default=None, help="where to write the PNGs (default: DATASET/figures)")
    s.set_defaults(run=run_show)


def run_dataset(args) -> int:
    from ..data.formats import save_dataset
    from ..data.generate import make_dataset
    from ..data.rig import RigConfig, noise_preset
    from ..scenes.registry import get_scene
    from ..scenes.render import RenderSettings

    scene = get_scene(args.scene, polygon=args.polygon, kind=args.kind)
    noise = noise_preset(args.noise)
    for key in noise:
        value = getattr(args, key)
        if value is not None:
            noise[key] = value
    rig = RigConfig(dim=2 if scene.kind == "2d" else 3, n_train=args.views, n_val=args.val, n_test=args.test,
                    radius=args.radius, resolution=args.resolution, fov=args.fov, layout=args.layout,
                    seed=args.seed, **noise)
    rig.validate()
    if args.spp < 1:
        from ..errors import MitnerfError
        raise MitnerfError(f"--spp must be at least 1, got {args.spp}")
    ds = make_dataset(scene, rig, RenderSettings(spp=args.spp, seed=args.seed))
    out = save_dataset(ds, args.out, args.format)
    counts = ", ".join(f"{k} {len(v)}" for k, v in ds.splits.items())
    print(f"wrote {out} ({scene.name}, {ds.dim}D, {counts}; near {ds.near:.3f}, far {ds.far:.3f})")
    return 0


def run_show(args) -> int:
    from ..data.formats import load_dataset
    from ..viz.rigs import plot_rig_2d, plot_rig_3d
    from ..viz.strips import split_figures

    ds = load_dataset(args.dataset)
    src = Path(args.dataset)
    out = Path(args.out) if args.out else (src / "figures" if src.is_dir() else src.with_suffix("") / "figures")
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, split in ds.splits.items():
        paths += split_figures(split, name, out, ds.background, ds.near, ds.far)
    cams = {k: v.cameras for k, v in ds.splits.items()}
    if ds.dim == 2:
        paths.append(plot_rig_2d(cams, ds.meta.get("polygon"), out / "rig.png", title=ds.meta.get("scene", "")))
    else:
        paths.append(plot_rig_3d(cams, ds.meta.get("mesh"), out / "rig.png", ds.meta.get("texture")))
    for p in paths:
        print(p)
    return 0
