"""``mitnerf video --checkpoint RUN --out DIR``: ``color`` and ``depth`` ``.gif``/``.mp4`` of a trained 3D field along
a path that fits its scene (``--path``: a 360 degree orbit of an object looking at the origin, a spiral in front of a
forward-facing capture, the capture's own path through an unbounded one; :mod:`mitnerf.viz.paths`) and, for an
object unless ``--no-mesh``, ``mesh.ply`` (the density isosurface at ``--level``), ``mesh.png`` (beside the ground
truth) and, when the dataset names its ground-truth mesh, ``chamfer.json`` (printed too). The last line reads
``video <n> frames <W>x<H> in <t> s (<fps> frames/s)``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._io import Output, json_text
from ..errors import MitnerfError
from ..geometry import CHAMFER_RESOLUTION, LEVEL, extract_mesh, field_chamfer
from ..scenes.objects3d import OBJECTS_3D
from ..scenes.registry import get_scene
from ..train.checkpoint import load_checkpoint
from ..viz.rigs import plot_mesh_comparison
from ..viz.paths import PATH_OF, path_cameras
from ..viz.video import OrbitConfig, orbit_cameras, orbit_video
from ..settings import setting
from .args import Writes, add_command, options, parse


def parse_level(text: str) -> str:
    """``auto`` or a positive, finite density (kept as text)."""
    if text != "auto":
        try:
            value = float(text)
        except ValueError:
            raise MitnerfError(f"--level must be a density (a number such as 10) or 'auto', got {text!r}") from None
        if not (value > 0 and value < float("inf")):
            raise MitnerfError(f"--level must be a positive, finite density, got {text}; try 3 or 'auto'")
    return text


@dataclass(kw_only=True)
class VideoCommand(Writes):
    """``mitnerf video``: a video of a trained 3D field along a path that fits its scene, and an object's mesh (the
    path's options: :class:`~mitnerf.viz.video.OrbitConfig`)."""

    checkpoint: str = setting(flag="--checkpoint", metavar="RUN")
    """A trained 3D model: the folder `mitnerf fit` wrote."""
    out: str = setting(flag="--out", metavar="DIR")
    """Folder for the videos and the mesh."""
    mesh: bool = setting(True, flag="--mesh")
    """Also extract the density's mesh and compare it with the ground truth (objects in a box only)."""
    level: str = setting(str(LEVEL), flag="--level", parse=parse_level, metavar="DENSITY|auto")
    """Density of the mesh surface, or auto (the level of mitnerf's geometry metrics); grid fields peak around
    10-30, so level 10 cuts holes in them."""
    mesh_resolution: int = setting(128, lo=2, hi=1024, flag="--mesh-resolution", unit="nodes per side")
    """Marching-cubes grid of the mesh."""
    backend: str | None = setting(None, choices=("drjit", "torch"), flag="--backend", shown="the checkpoint's")
    """Engine that renders."""


def register(sub) -> None:
    add_command(sub, "video", VideoCommand, run, (OrbitConfig, "orbit."),
                help="a video (colour, depth) of a trained 3D field along a path that fits its scene, and its mesh")


def ground_truth(meta: dict) -> tuple[Path | None, Path | None]:
    """The ground-truth mesh and texture a dataset names (``None``: missing); deleted scene assets are rebuilt."""
    mesh, texture = meta.get("mesh"), meta.get("texture")
    if mesh and not Path(mesh).exists() and meta.get("scene") in OBJECTS_3D:
        info = get_scene(meta["scene"])
        mesh, texture = info.mesh, info.variables.get("texture")
    return tuple(Path(p) if p and Path(p).exists() else None for p in (mesh, texture))


def run(args) -> int:
    cfg, args = OrbitConfig(**options(OrbitConfig, args, "orbit.")), parse(args)
    cfg.validate()
    level = args.level if args.level == "auto" else float(args.level)
    target = Output(args.out, "video", args.overwrite, inputs=[args.checkpoint])
    model, _ = load_checkpoint(args.checkpoint, args.backend, dim=3, need="`mitnerf video` (a 3D field)")
    render = model.recipe.model.render
    scene = "object" if render.scene == "auto" else render.scene
    path = PATH_OF[scene] if cfg.path == "auto" else cfg.path
    capture = model.dataset_meta.get("cameras")
    if path != "orbit" and not capture:
        raise MitnerfError(f"--path {path} follows the training cameras, which {args.checkpoint} does not record (an "
                           "object's run); pass --path orbit")
    cams = orbit_cameras(cfg) if path == "orbit" else path_cameras(path, capture, cfg.n_frames, cfg.resolution,
                                                                   *depth_range(model))     # refused before the line
    print(f"path: {PATH_WORDS[path]} ({'--path' if cfg.path != 'auto' else 'the run is ' + SCENE_WORDS[scene]}; "
          "--path chooses)", flush=True)
    with target.staged() as tmp:
        video = orbit_video(model.backend, cfg, tmp, render.render_background(), cameras=cams)
        if args.mesh and scene == "object":
            write_mesh_outputs(model, tmp, level, args.mesh_resolution, cfg)
    for name in ("color.gif", "color.mp4", "depth.gif", "depth.mp4", "mesh.ply", "mesh.png", "chamfer.json"):
        if (target.path / name).exists():
            print(f"wrote {target.path / name}")
    print(video.summary())
    return 0


PATH_WORDS = {"orbit": "a 360 degree orbit around the object", "spiral": "a spiral in front of the capture",
              "capture": "along the capture's own camera path"}
SCENE_WORDS = {"object": "of an object in a box", "forward": "of a forward-facing scene",
               "unbounded": "of an unbounded scene"}


def depth_range(model) -> tuple[float, float]:
    """The nearest and farthest depths of the capture (LLFF's bounds, else the run's near and far): the spiral's
    focus."""
    bounds = model.dataset_meta.get("bounds")
    if bounds:
        b = np.asarray(bounds, np.float64)
        return float(b[:, 0].min()), float(b[:, 1].max())
    return model.backend.near, model.backend.far


def write_mesh_outputs(model, out: Path, level, resolution: int, cfg, progress: bool = True) -> dict:
    """``mesh.ply``, ``mesh.png`` and (with a ground truth) ``chamfer.json``: the Chamfer distance by mitnerf's one
    definition (:func:`~mitnerf.geometry.field_chamfer`, what ``fit`` reports); prints what it found."""
    try:
        mesh = extract_mesh(model.backend.density, model.bound, resolution, level, progress=progress)
    except MitnerfError as exc:
        raise MitnerfError(f"the mesh failed (nothing was written): {exc}; pass that level with "
                           "--level (or --level auto), or skip the mesh with --no-mesh") from None
    mesh.save(out / "mesh.ply")
    print(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces at density level "
          f"{mesh.level:.3g} ({resolution}^3 grid in {mesh.info['seconds']:.3g} s)")
    truth, texture = ground_truth(model.dataset_meta)
    result, note = {"level": mesh.level, "vertices": len(mesh.vertices), "faces": len(mesh.faces)}, ""
    if truth is None:
        print("no ground-truth mesh in the checkpoint's dataset metadata: no Chamfer distance")
    else:
        same = resolution == CHAMFER_RESOLUTION and level == LEVEL          # the mesh mitnerf's Chamfer measures
        try:
            c = field_chamfer(model.backend.density, model.bound, truth, mesh if same else None, progress)
        except MitnerfError as exc:
            c = None
            print(f"no Chamfer distance: it measures the surface at density {LEVEL:g}, and {exc}")
        if c is not None:
            result.update(truth=str(truth), chamfer=c.chamfer, learned_to_truth=c.a_to_b, truth_to_learned=c.b_to_a,
                          n_points=c.n_points, sampling_floor=c.floor)
            (out / "chamfer.json").write_text(json_text(result))
            note = str(c)
            print(f"{note} against {truth.name}")
    plot_mesh_comparison(mesh, truth, out / "mesh.png", texture, note=note, elevation=cfg.elevation,
                         distance=cfg.radius, fov=cfg.fov)
    return result
