"""Window shopping in 3D: a few photos of a product in, a turn-table video and a mesh out.

A seller posts a handful of photos of a product; a buyer wants to turn it around. This
script takes the photos, trains a radiance field on them and writes what the buyer
looks at, end to end, with one progress bar over the five stages
(photos -> train -> test -> video -> mesh):

1. **Photos**: ``--views`` random, slightly noisy viewpoints on the upper hemisphere of
   a 3D object of ours (``--scene``, default ``vase``; rendered once, then cached), or
   your own data with ``--data PATH`` (a Blender/nerfstudio ``transforms.json`` folder or
   ``tiny_nerf_data.npz``, read by :func:`mitnerf.data.formats.load_dataset`; ``--views N``
   keeps N of its training frames, evenly spread through the file's order; 0 keeps all).
2. **Train** the field (``--field``, default ``grid``: the dense voxel grid, the fastest
   on a CPU) from its preset (:func:`mitnerf.train.presets.preset`) for
   ``--time-budget`` seconds.
3. **Test**: PSNR and SSIM on held-out views. For our scenes these lie on the buyer's
   own path (a 360 degree orbit at 25 degrees elevation, radius 3.5, no noise).
4. **Video**: ``color.gif/.mp4`` and ``depth.gif/.mp4``, one 360 degree orbit of
   ``--frames`` frames (:mod:`mitnerf.viz.video`). For our scenes the orbit is the test
   orbit; for your data it circles the origin (z up) at the training cameras' median
   distance and elevation, with their field of view.
5. **Mesh**: ``mesh.ply``, the isosurface of the learned density at ``--level``
   (:mod:`mitnerf.geometry.mesh`), ``mesh.png`` beside the ground-truth mesh and, when
   the ground truth is known (our scenes), the Chamfer distance in ``chamfer.json``
   (:mod:`mitnerf.geometry.chamfer`: mean of the two one-sided mean distances, world units;
   the objects fit the unit sphere).

Also written: ``checkpoint/`` (``python -m mitnerf video --checkpoint OUT/checkpoint``
re-renders it) and ``summary.json`` with every figure printed at the end::

    python examples/window_shopping.py                              # vase, 25 views, grid, 60 s
    python examples/window_shopping.py --scene nut --views 5
    python examples/window_shopping.py --data tiny_nerf_data.npz --views 25
    python examples/window_shopping.py --field hashgrid --time-budget 120

The mesh level defaults to 3 (as in ``mitnerf video``), not 10: the grid field spreads a
surface over a few voxels and its density peaks near 10-30, so level 10 cuts holes into
the vase. Chamfer distance of the grid vase (25 views, 60 s) against the true mesh, by
level: auto (0.22) 0.042, 1: 0.024, 3: 0.013, 10: 0.059, 30: 0.53 (30 000 samples each).

Measured (grid, vase, 100x100 photos, 60 s of training unless noted, 120-frame 100x100
video, mesh at level 3 on a 128^3 grid, Chamfer with 100 000 samples; 2 CPU cores shared
with other jobs at load average 2-4, so times are upper bounds):

=============  =========  =====  =====  ============  ===========  =======
photos         test PSNR  SSIM   steps  render/frame  video (120)  Chamfer
=============  =========  =====  =====  ============  ===========  =======
5              23.41 dB   0.877  942    35 ms         4.4 s        0.050
10             25.48 dB   0.929  922    37 ms         4.4 s        0.037
25             31.68 dB   0.976  945    29 ms         4.4 s        0.012
25, 20 s       31.19 dB   0.974  780    19 ms         2.3 s        --
=============  =========  =====  =====  ============  ===========  =======

At load average 5-7 the 25-photo run made 735 steps (31.0 dB) and the video took 7.0 s.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

import mitnerf  # noqa: F401  (selects the Mitsuba variant, checks LLVM)
from mitnerf.errors import MitnerfError
from mitnerf.train.presets import preset, preset_fields

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("photos", "train", "test", "video", "mesh")


def parse_args(argv=None) -> argparse.Namespace:
    from mitnerf.scenes.objects3d import OBJECTS_3D

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    src = p.add_mutually_exclusive_group()
    src.add_argument("--scene", choices=OBJECTS_3D, default="vase", help="3D object of ours to photograph")
    src.add_argument("--data", default=None, help="Blender/nerfstudio folder or tiny_nerf_data.npz instead")
    p.add_argument("--views", type=int, default=25, help="training photos (with --data: 0 keeps all)")
    p.add_argument("--resolution", type=int, default=100, help="photo width and height (our scenes)")
    p.add_argument("--field", choices=preset_fields(), default="grid", help="field family (its preset)")
    p.add_argument("--time-budget", type=float, default=60.0, help="seconds of training")
    p.add_argument("--iters", type=int, default=None, help="at most this many steps (default: no cap)")
    p.add_argument("--frames", type=int, default=120, help="video frames in one turn")
    p.add_argument("--video-resolution", type=int, default=100, help="video frame width and height")
    p.add_argument("--fps", type=float, default=30.0, help="video playback rate")
    p.add_argument("--mesh", action=argparse.BooleanOptionalAction, default=True, help="extract the mesh")
    p.add_argument("--level", default="3", help="density of the mesh surface, or 'auto' (see the docstring)")
    p.add_argument("--mesh-resolution", type=int, default=128, help="marching-cubes grid nodes per side")
    p.add_argument("--chamfer-points", type=int, default=100_000, help="surface samples per mesh")
    p.add_argument("--seed", type=int, default=0, help="seed of the viewpoints and the training")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="progress bars")
    p.add_argument("--out", default=None, help="default: out/window_shopping/<scene>-<field>-<views>v")
    args = p.parse_args(argv)
    if args.views < 0 or (args.data is None and args.views < 1):
        p.error(f"--views must be at least 1 (0 keeps all frames of --data), got {args.views}")
    if not args.time_budget > 0:
        p.error(f"--time-budget must be positive seconds, got {args.time_budget}")
    if args.frames < 1 or args.video_resolution < 2:     # checked now, not after a minute of training
        p.error(f"need --frames >= 1 and --video-resolution >= 2, got {args.frames} and {args.video_resolution}")
    if args.mesh and args.mesh_resolution < 2:
        p.error(f"--mesh-resolution must be at least 2, got {args.mesh_resolution}; use 128 (or --no-mesh)")
    return args


def load_photos(args):
    """The dataset (train/val/test) and the rig it came from (None for --data)."""
    if args.data is None:
        from mitnerf.data.rig import RigConfig, noise_preset
        from mitnerf.experiments.common import cached_dataset

        rig = RigConfig(dim=3, n_train=args.views, n_val=2, n_test=8, resolution=args.resolution,
                        seed=args.seed, **noise_preset(1.0))
        return cached_dataset(args.scene, rig), rig
    from mitnerf.data.formats import load_dataset

    ds = load_dataset(args.data)
    if ds.dim != 3:
        raise MitnerfError(f"{args.data} holds a 2D dataset; window shopping needs 3D photos "
                           "(a Blender/nerfstudio folder or tiny_nerf_data.npz)")
    n = len(ds["train"])
    if 0 < args.views < n:
        ds.splits["train"] = ds["train"].subset(np.linspace(0, n - 1, args.views).round().astype(int))
    return ds, None


def orbit_for(ds, rig, args):
    """The buyer's orbit: the test orbit of our rigs, or one fitted to foreign cameras."""
    from mitnerf.viz.video import OrbitConfig

    if rig is not None:
        return OrbitConfig(n_frames=args.frames, resolution=args.video_resolution, elevation=rig.test_elevation,
                           radius=rig.radius, fov=40.0 if rig.fov is None else rig.fov, fps=args.fps)
    cams = ds["train"].cameras
    o = cams.origins                                                          # [n, 3]
    r = np.linalg.norm(o, axis=1)                                             # [n]
    elevation = float(np.clip(np.degrees(np.median(np.arcsin(o[:, 2] / r))), -60.0, 60.0))
    return OrbitConfig(n_frames=args.frames, resolution=args.video_resolution, elevation=elevation,
                       radius=float(np.median(r)), fov=float(cams.fov), fps=args.fps)


def train(ds, args):
    from mitnerf.train.trainer import fit

    model_cfg, train_cfg = preset(args.field, 3)
    model_cfg.render.background = ds.background
    train_cfg.time_budget = args.time_budget
    train_cfg.iters = args.iters if args.iters is not None else 1_000_000   # the clock decides
    train_cfg.seed, train_cfg.progress = args.seed, args.progress
    return fit(ds, model_cfg, train_cfg)


def first_time_at(history: dict, target: float) -> float | None:
    """Training seconds at the first validation reaching ``target`` dB (None: never)."""
    for t, v in zip(history["val_time"], history["val_psnr"]):
        if v >= target:
            return float(t)
    return None


def window_shop(args) -> dict:
    """Run every stage; returns the summary (also written to ``summary.json``)."""
    from mitnerf.cli.video_cmd import parse_level, write_mesh_outputs
    from mitnerf.train.checkpoint import save_checkpoint
    from mitnerf.train.trainer import evaluate
    from mitnerf.viz.video import orbit_video

    level = parse_level(args.level)
    name = Path(args.data).stem if args.data else args.scene
    out = Path(args.out or ROOT / "out" / "window_shopping" / f"{name}-{args.field}-{args.views}v")
    out.mkdir(parents=True, exist_ok=True)
    s = {"object": name, "field": args.field, "time_budget": args.time_budget}
    start = time.perf_counter()
    with tqdm(total=len(STAGES), desc="window shopping", unit="stage", disable=not args.progress) as bar:
        def stage(k):
            bar.set_postfix_str(STAGES[k], refresh=True)

        stage(0)
        t0 = time.perf_counter()
        ds, rig = load_photos(args)
        H, W = ds["train"].cameras.height, ds["train"].cameras.width
        s.update(views=len(ds["train"]), photo_size=f"{W}x{H}", data_seconds=time.perf_counter() - t0)
        bar.update()

        stage(1)
        run = train(ds, args)
        save_checkpoint(run, out / "checkpoint")
        s.update(train_time=run.train_time, steps=run.steps,
                 val_psnr=run.history["val_psnr"][-1] if run.history["val_psnr"] else None,
                 seconds_to_28db_val=first_time_at(run.history, 28.0))
        bar.update()

        stage(2)
        ev = evaluate(run, ds, "test")
        s.update(test_views=len(ds["test"]), test_psnr=ev["psnr"], test_ssim=ev["ssim"],
                 render_seconds_per_view=ev["render_time_per_view"], depth_error=ev.get("depth_error"))
        bar.update()

        stage(3)
        cfg = orbit_for(ds, rig, args)
        video = orbit_video(run.backend, cfg, out, run.model_cfg.render.background, progress=args.progress)
        n, fh, fw = video.frames.depth.shape
        s.update(orbit={k: getattr(cfg, k) for k in ("elevation", "radius", "fov", "fps")},
                 video_frames=n, video_size=f"{fw}x{fh}", video_render_seconds=video.frames.seconds,
                 video_write_seconds=video.write_seconds, video_files={k: str(v) for k, v in video.paths.items()})
        bar.update()

        stage(4)
        log = io.StringIO()
        if args.mesh:
            with contextlib.redirect_stdout(log):        # printed below, after the bar
                t0 = time.perf_counter()
                try:
                    mesh = write_mesh_outputs(run, out, level, args.mesh_resolution, args.chamfer_points, cfg,
                                              progress=args.progress)
                except MitnerfError:                     # no surface at that level: let the field choose
                    if level == "auto":
                        raise
                    print(f"no surface at density level {args.level} in this field; using --level auto instead")
                    mesh = write_mesh_outputs(run, out, "auto", args.mesh_resolution, args.chamfer_points, cfg,
                                              progress=args.progress)
            s.update(mesh_seconds=time.perf_counter() - t0, mesh=mesh)
        bar.update()
    s["total_seconds"] = time.perf_counter() - start
    (out / "summary.json").write_text(json.dumps(s, indent=1, default=str))
    s["out"], s["mesh_log"] = str(out), log.getvalue()
    return s


def report_lines(s: dict) -> list[str]:
    lines = [f"window shopping: {s['object']}, {s['views']} photos of {s['photo_size']}, {s['field']} field",
             f"test PSNR {s['test_psnr']:.2f} dB, SSIM {s['test_ssim']:.3f} ({s['test_views']} held-out views)",
             f"train {s['train_time']:.1f} s ({s['steps']} steps)"
             + (f"; validation reached 28 dB after {s['seconds_to_28db_val']:.1f} s"
                if s.get("seconds_to_28db_val") is not None else ""),
             f"render {1000 * s['render_seconds_per_view']:.0f} ms per {s['photo_size']} frame",
             f"video {s['video_frames']} frames {s['video_size']} rendered in {s['video_render_seconds']:.2f} s "
             f"({s['video_frames'] / max(s['video_render_seconds'], 1e-9):.1f} frames/s), "
             f"files written in {s['video_write_seconds']:.2f} s"]
    mesh = s.get("mesh")
    if mesh:
        lines.append(f"mesh {mesh['vertices']} vertices at density {mesh['level']:.3g} in {s['mesh_seconds']:.1f} s"
                     + (f"; Chamfer distance {mesh['chamfer']:.4f} (learned->truth {mesh['learned_to_truth']:.4f}, "
                        f"truth->learned {mesh['truth_to_learned']:.4f}; world units)"
                        if "chamfer" in mesh else "; no ground-truth mesh, no Chamfer distance"))
    lines.append(f"end to end {s['total_seconds']:.1f} s")
    return lines


def main(argv=None) -> int:
    args = parse_args(argv)
    from mitnerf.train.trainer import TrainingFailed

    try:
        s = window_shop(args)
    except (MitnerfError, TrainingFailed) as exc:
        print(f"window_shopping: {exc}", file=sys.stderr)
        return 2
    print(s["mesh_log"], end="")
    print(f"wrote {s['out']}: color.gif/.mp4, depth.gif/.mp4"
          + (", mesh.ply, mesh.png" if args.mesh else "") + ", checkpoint/, summary.json")
    for line in report_lines(s):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
