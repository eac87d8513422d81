"""``mitnerf dataset`` (render a dataset) and ``mitnerf show`` (its pictures)."""

from __future__ import annotations

from pathlib import Path

from .._io import Output, atomic_write_bytes
from ..data.formats import DIMS, FORMATS, WRITERS, check_output, load_dataset, tiny_nerf_bytes
from ..data.generate import make_dataset
from ..data.rig import RigConfig, noise_preset
from ..errors import ConfigError
from ..scenes.gt_render import RenderSettings
from ..scenes.looks import MATERIALS
from ..scenes.registry import get_scene
from ..viz.rigs import plot_rig_2d, plot_rig_3d
from ..viz.strips import split_figures
from .args import number


def register(sub) -> None:
    p = sub.add_parser("dataset", help="render a dataset of a scene")
    p.add_argument("--scene", help="scene name (with an optional look: bunny_glossy, "
                   "vase_plastic_env), or a path to a Mitsuba XML file")
    p.add_argument("--polygon", help="JSON file with a closed ring of [x, y] points (a 2D scene)")
    p.add_argument("--out", required=True, help="output folder (new, empty, or an earlier dataset of mitnerf's)")
    p.add_argument("--overwrite", action="store_true", help="write into a folder that holds other files "
                   "(they are left alone)")
    p.add_argument("--views", type=number(True, 0, 100_000), default=50, help="training views")
    p.add_argument("--val", type=number(True, 0, 100_000), default=10, help="validation views")
    p.add_argument("--test", type=number(True, 0, 100_000), default=20, help="test views (evenly spaced, noise-free)")
    p.add_argument("--resolution", type=number(True, 0, 16384), default=100, help="pixels (per side in 3D)")
    p.add_argument("--radius", type=number(False, 0, 1e4, True), help="camera distance (default 4 in 2D, 3.5 in 3D)")
    p.add_argument("--fov", type=number(False, 0, 179, True), help="field of view in degrees")
    p.add_argument("--layout", choices=["random", "even"], default="random", help="train/val placement")
    p.add_argument("--noise", type=number(False, 0, 100), default=1.0,
                   help="scale of all placement noise (1: radius 0.1, angle 2 deg, position 0.05, look 1 deg)")
    for name in ("radius-std", "angle-std", "position-std", "look-std"):
        p.add_argument(f"--{name}", type=number(False, 0, 1e4), help="override one noise parameter")
    p.add_argument("--spp", type=number(True, 1, 1 << 16), help="samples per pixel for colour "
                   "(default: converged, 64 with all_lights, 1024 with path; fewer gives a noisy ground truth)")
    p.add_argument("--material", choices=list(MATERIALS), help="surface: diffuse (default), plastic (needs --env), "
                   "roughplastic, roughconductor, or textured (a barcode along a 2D outline)")
    p.add_argument("--roughness", type=number(False, 0, 1, True), help="GGX roughness of roughplastic (default "
                   "0.25) or roughconductor (0.3): smaller gives sharper highlights")
    p.add_argument("--env", action="store_true", help="light the scene by a sky with a sun instead of point lights")
    p.add_argument("--integrator", choices=["all_lights", "path"], help="all_lights: noise-free sum over point "
                   "lights (default); path: Mitsuba's path tracer (default with --env)")
    p.add_argument("--seed", type=number(True, 0, 2 ** 32 - 1), default=0,
                   help="seed of placement noise and of the renderer")
    p.add_argument("--format", choices=list(FORMATS),
                   help="file format (default: nerf2d for 2D, blender for 3D)")
    p.add_argument("--kind", choices=["2d", "3d"], help="kind of a scene given as XML")
    p.set_defaults(run=run_dataset)

    s = sub.add_parser("show", help="write the views strip, depth strip and rig plot of a dataset")
    s.add_argument("dataset", help="dataset folder (or tiny-NeRF .npz)")
    s.add_argument("--out", help="where to write the PNGs (default: DATASET/figures)")
    s.set_defaults(run=run_show)


def run_dataset(args) -> int:
    scene = get_scene(args.scene, polygon=args.polygon, kind=args.kind, material=args.material, env=args.env,
                      roughness=args.roughness)
    integrator = args.integrator or ("path" if scene.lighting == "env" else "all_lights")
    spp = args.spp or (1024 if integrator == "path" else 64)
    dim = 2 if scene.kind == "2d" else 3
    fmt = args.format or ("nerf2d" if dim == 2 else "blender")
    if dim not in DIMS.get(fmt, (3,)):
        fits = [f for f in FORMATS if dim in DIMS.get(f, (3,))]
        raise ConfigError(f"--format {fmt} cannot hold a {dim}D dataset; use {', '.join(fits[:-1])} or {fits[-1]}")
    noise = {k: v if getattr(args, k) is None else getattr(args, k) for k, v in noise_preset(args.noise).items()}
    rig = RigConfig(dim=dim, n_train=args.views, n_val=args.val, n_test=args.test, radius=args.radius,
                    resolution=args.resolution, fov=args.fov, layout=args.layout, seed=args.seed, **noise)
    rig.validate()
    target = check_output(args.out, fmt, args.overwrite)          # refused before rendering
    ds = make_dataset(scene, rig, RenderSettings(spp=spp, seed=args.seed, integrator=integrator))
    if target is None:
        atomic_write_bytes(Path(args.out), tiny_nerf_bytes(ds))
    else:
        with target.staged() as tmp:
            WRITERS[fmt](ds, tmp)
    counts = ", ".join(f"{k} {len(v)}" for k, v in ds.splits.items())
    print(f"wrote {args.out} ({scene.name}, {ds.dim}D, {counts}; near {ds.near:.3f}, far {ds.far:.3f})")
    return 0


def run_show(args) -> int:
    ds = load_dataset(args.dataset)
    src = Path(args.dataset)
    out = Path(args.out) if args.out else (src / "figures" if src.is_dir() else src.with_suffix("") / "figures")
    paths = []
    with Output(out, "figures").staged() as tmp:
        for name, split in ds.splits.items():
            paths += split_figures(split, name, tmp, ds.background, ds.near, ds.far)
        cams = {k: v.cameras for k, v in ds.splits.items()}
        if ds.dim == 2:
            paths.append(plot_rig_2d(cams, ds.meta.get("polygon"), tmp / "rig.png", title=ds.meta.get("scene", "")))
        else:
            paths.append(plot_rig_3d(cams, ds.meta.get("mesh"), tmp / "rig.png", ds.meta.get("texture")))
    for p in paths:
        print(out / Path(p).name)
    return 0
