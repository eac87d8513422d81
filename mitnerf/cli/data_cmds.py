"""``mitnerf dataset`` (render a dataset) and ``mitnerf show`` (its pictures)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from .._io import Output, write_new_file
from ..data.cameras import check_pixel_memory
from ..data.formats import DATASET_BYTES_PER_PIXEL, DIMS, FORMATS, WRITERS, check_output, load_dataset, tiny_nerf_bytes
from ..data.generate import make_dataset
from ..data.rig import RigConfig, noise_preset
from ..errors import ConfigError
from ..scenes.gt_render import RenderSettings
from ..scenes.looks import MATERIALS
from ..scenes.registry import get_scene
from ..settings import setting, show_value
from ..viz.rigs import plot_rig_2d, plot_rig_3d
from ..viz.views import split_figures
from .args import Writes, add_command, options, parse


@dataclass(kw_only=True)
class DatasetCommand(Writes):
    """``mitnerf dataset``: render a dataset of a scene (the rig's options: :class:`~mitnerf.data.rig.RigConfig`)."""

    scene: str | None = setting(None, flag="--scene", metavar="NAME|FILE.xml", shown="none; give --scene or "
                                "--polygon")
    """A scene by name, with an optional look (bunny, vase, bunny_glossy, vase_plastic_env), or a Mitsuba XML
    file."""
    polygon: str | None = setting(None, flag="--polygon", metavar="FILE.json", shown="none")
    """A JSON file holding a ring of [x, y] points: a 2D scene of your own."""
    out: str = setting(flag="--out", metavar="DIR")
    """Output folder: new, empty, or an earlier dataset of mitnerf's."""
    noise: float = setting(1.0, lo=0, hi=100, flag="--noise")
    """Scale of all placement noise: 1 is radius 0.1, angle 2 degrees, position 0.05, look 1 degree."""
    spp: int | None = setting(None, lo=1, hi=1 << 16, flag="--spp", unit="samples per pixel",
                              shown="converged: 64, or 1024 with the path tracer")
    """Samples per pixel for colour; fewer than converged gives a noisy ground truth."""
    material: str | None = setting(None, choices=MATERIALS, flag="--material", shown="the scene's, diffuse")
    """Surface: diffuse, plastic (needs --env), roughplastic, roughconductor, or textured (a barcode along a 2D
    outline)."""
    roughness: float | None = setting(None, lo=0, above=True, hi=1, flag="--roughness",
                                      shown="roughplastic 0.25, roughconductor 0.3")
    """GGX roughness of roughplastic or roughconductor: smaller gives sharper highlights."""
    env: bool = setting(False, flag="--env")
    """Light the scene by a sky with a sun instead of point lights."""
    integrator: str | None = setting(None, choices=("all_lights", "path"), flag="--integrator",
                                     shown="all_lights, path with --env")
    """all_lights: a noise-free sum over point lights; path: Mitsuba's path tracer (what --env needs)."""
    format: str | None = setting(None, choices=FORMATS, flag="--format", shown="nerf2d in 2D, blender in 3D")
    """File format."""
    kind: str | None = setting(None, choices=("2d", "3d"), flag="--kind", shown="read from the XML")
    """Kind of a scene given as XML."""


@dataclass(kw_only=True)
class ShowCommand(Writes):
    """``mitnerf show``: the pictures of a dataset."""

    dataset: str = setting(flag="dataset")
    """Dataset folder (or tiny-NeRF .npz)."""
    out: str | None = setting(None, flag="--out", metavar="DIR", shown="out/show/<the dataset's name>")
    """Where to write the PNGs."""


def rig_default(key: str) -> str:
    if key.endswith("_std"):
        return "from --noise"
    return {"rig.radius": "4 in 2D, 3.5 in 3D", "rig.fov": "53.13 in 2D, 40 in 3D"}.get(
        key, show_value(getattr(RigConfig(), key.split(".", 1)[1])))


def register(sub) -> None:
    add_command(sub, "dataset", DatasetCommand, run_dataset, (RigConfig, "rig.", rig_default),
                help="render a dataset of a scene (ground truth by Mitsuba 3)")
    add_command(sub, "show", ShowCommand, run_show, help="write a dataset's pictures: views, depth, the camera rig")


def run_dataset(args) -> int:
    rig_given, args = options(RigConfig, args, "rig."), parse(args)
    scene = get_scene(args.scene, polygon=args.polygon, kind=args.kind, material=args.material, env=args.env,
                      roughness=args.roughness)
    integrator = args.integrator or ("path" if scene.lighting == "env" else "all_lights")
    spp = args.spp or (1024 if integrator == "path" else 64)
    dim = 2 if scene.kind == "2d" else 3
    fmt = args.format or ("nerf2d" if dim == 2 else "blender")
    if dim not in DIMS.get(fmt, (3,)):
        fits = [f for f in FORMATS if dim in DIMS.get(f, (3,))]
        raise ConfigError(f"--format {fmt} cannot hold a {dim}D dataset; use {', '.join(fits[:-1])} or {fits[-1]}")
    rig = RigConfig(dim=dim, **{**noise_preset(args.noise), **rig_given})
    rig.validate()
    views = rig.n_train + rig.n_val + rig.n_test
    pixels = views * rig.resolution ** (dim - 1)
    check_pixel_memory(views, rig.resolution, rig.resolution if dim == 3 else 1)
    inputs = [args.polygon, args.scene if args.scene and Path(args.scene).exists() else None]
    target = check_output(args.out, fmt, args.overwrite, inputs, size=pixels * DATASET_BYTES_PER_PIXEL)
    ds = make_dataset(scene, rig, RenderSettings(spp=spp, seed=rig.seed, integrator=integrator))
    if target is None:
        write_new_file(args.out, tiny_nerf_bytes(ds))
        where = args.out
    else:
        with target.staged() as tmp:
            WRITERS[fmt](ds, tmp)
        where = target.path
    counts = ", ".join(f"{k} {len(v)}" for k, v in ds.splits.items())
    print(f"wrote {where} ({scene.name}, {ds.dim}D, {counts}; near {ds.near:.3f}, far {ds.far:.3f})")
    return 0


def run_show(args) -> int:
    args = parse(args)
    ds = load_dataset(args.dataset)
    out = Path(args.out) if args.out else Path("out", "show", Path(os.path.abspath(args.dataset)).stem)
    target, paths = Output(out, "figures", args.overwrite, inputs=[args.dataset]), []
    with target.staged() as tmp:
        for name, split in ds.splits.items():
            paths += split_figures(split, name, tmp, ds.background, ds.near, ds.far, title=ds.name)
        cams = {k: v.cameras for k, v in ds.splits.items()}
        if ds.dim == 2:
            paths.append(plot_rig_2d(cams, ds.meta.get("polygon"), tmp / "rig.png", title=ds.meta.get("scene", "")))
        else:
            paths.append(plot_rig_3d(cams, ds.meta.get("mesh"), tmp / "rig.png", ds.meta.get("texture")))
    for p in paths:
        print(target.path / Path(p).name)
    return 0
