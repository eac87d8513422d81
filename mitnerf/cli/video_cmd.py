"""``mitnerf video --checkpoint RUN --out DIR``: ``color`` and ``depth`` ``.gif``/``.mp4`` (a 360 degree orbit of a
trained 3D field, looking at the origin) and, unless ``--no-mesh``, ``mesh.ply`` (the density isosurface at
``--level``), ``mesh.png`` (beside the ground truth) and, when the dataset names its ground-truth mesh,
``chamfer.json`` (printed too). The last line reads ``video <n> frames <W>x<H> in <t> s (<fps> frames/s)``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .._io import Output
from ..errors import MitnerfError
from ..geometry import LEVEL, chamfer_distance, extract_mesh
from ..scenes.objects3d import OBJECTS_3D
from ..scenes.registry import get_scene
from ..train.checkpoint import load_checkpoint
from ..viz.rigs import plot_mesh_comparison
from ..viz.video import OrbitConfig, orbit_video
from .args import number


def parse_level(text: str) -> float | str:
    if text == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        raise MitnerfError(f"--level must be a density (a number such as 10) or 'auto', got {text!r}") from None
    if not (value > 0 and value < float("inf")):
        raise MitnerfError(f"--level must be a positive, finite density, got {text}; try 3 or 'auto'")
    return value


def register(sub) -> None:
    p = sub.add_parser("video", help="turn-table video (colour, depth) and mesh of a trained 3D field",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--checkpoint", required=True, help="checkpoint folder (the --out of `mitnerf fit`)")
    p.add_argument("--out", required=True, help="folder for the videos and the mesh")
    p.add_argument("--overwrite", action="store_true", help="write into a folder that holds other files")
    p.add_argument("--frames", type=number(True, 1, 100_000), default=120, help="frames in one 360 degree turn")
    p.add_argument("--resolution", type=number(True, 1, 4096), default=100, help="frame width and height in pixels")
    p.add_argument("--elevation", type=number(False, -90, 90), default=25.0, help="camera elevation in degrees")
    p.add_argument("--radius", type=number(False, 0, 1e4, True), default=3.5, help="camera distance from the origin")
    p.add_argument("--fov", type=number(False, 0, 179, True), default=40.0, help="horizontal field of view, degrees")
    p.add_argument("--fps", type=number(False, 0, 1000, True), default=30.0, help="playback frames per second")
    p.add_argument("--mesh", action=argparse.BooleanOptionalAction, default=True,
                   help="also extract the mesh, compare it with the ground truth")
    p.add_argument("--level", default=str(LEVEL), help="density of the mesh surface, or 'auto' (the level of "
                   "mitnerf's geometry metrics; grid fields peak around 10-30, so level 10 cuts holes in them)")
    p.add_argument("--mesh-resolution", type=number(True, 2, 1024), default=128, help="marching-cubes nodes per side")
    p.add_argument("--chamfer-points", type=number(True, 1, 10 ** 7), default=100_000, help="surface samples per mesh")
    p.add_argument("--backend", choices=["drjit", "torch"], help="default: the checkpoint's")
    p.set_defaults(run=run)


def ground_truth(meta: dict) -> tuple[Path | None, Path | None]:
    """The ground-truth mesh and texture a dataset names (``None``: missing); deleted scene assets are rebuilt."""
    mesh, texture = meta.get("mesh"), meta.get("texture")
    if mesh and not Path(mesh).exists() and meta.get("scene") in OBJECTS_3D:
        info = get_scene(meta["scene"])
        mesh, texture = info.mesh, info.variables.get("texture")
    return tuple(Path(p) if p and Path(p).exists() else None for p in (mesh, texture))


def run(args) -> int:
    level = parse_level(args.level)
    cfg = OrbitConfig(n_frames=args.frames, resolution=args.resolution, elevation=args.elevation,
                      radius=args.radius, fov=args.fov, fps=args.fps)
    cfg.validate()
    target = Output(args.out, "video", args.overwrite, inputs=[args.checkpoint])
    model, _ = load_checkpoint(args.checkpoint, args.backend, dim=3, need="`mitnerf video` (a 360 degree orbit)")
    with target.staged() as tmp:
        video = orbit_video(model.backend, cfg, tmp, model.recipe.model.render.render_background())
        if args.mesh:
            write_mesh_outputs(model, tmp, level, args.mesh_resolution, args.chamfer_points, cfg)
    for name in ("color.gif", "color.mp4", "depth.gif", "depth.mp4", "mesh.ply", "mesh.png", "chamfer.json"):
        if (target.path / name).exists():
            print(f"wrote {target.path / name}")
    print(video.summary())
    return 0


def write_mesh_outputs(model, out: Path, level, resolution: int, n_points: int, cfg, progress: bool = True) -> dict:
    """``mesh.ply``, ``mesh.png`` and (with a ground truth) ``chamfer.json``; prints what it found."""
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
        c = chamfer_distance(mesh, truth, n_points=n_points, seed=0)
        result.update(truth=str(truth), chamfer=c.chamfer, learned_to_truth=c.a_to_b, truth_to_learned=c.b_to_a,
                      n_points=c.n_points, sampling_floor=c.floor)
        (out / "chamfer.json").write_text(json.dumps(result, indent=1))
        note = str(c)
        print(f"{note} against {truth.name}")
    plot_mesh_comparison(mesh, truth, out / "mesh.png", texture, note=note, elevation=cfg.elevation,
                         distance=cfg.radius, fov=cfg.fov)
    return result
