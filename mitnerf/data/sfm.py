"""Structure from motion: the poses, intrinsics and sparse points of a folder of photographs, found by COLMAP's own
algorithms through pycolmap (an optional extra: ``pip install -e .[poses]``) on the CPU.

Stages, one progress line each (counts and seconds): the photographs copied and checked; SIFT features
(:class:`SfmConfig`: the camera model, one camera for all or one per image, features at most
``max_image_size`` pixels a side); matching, every pair (exhaustive) or each image with its next ones in name
order (sequential: video frames); incremental mapping, whose largest model is kept. Images it cannot register
are listed in one warning line; fewer than :data:`MIN_IMAGES`, or under ``min_registered`` of them, is refused.

The world written is COLMAP's model moved by one similarity (``meta['poses']['world_from_colmap']``): the
cameras' mean up direction along +z, the origin at the point their optical axes pass closest to (the median
sparse point for a forward-facing capture: :func:`~.formats.capture.layout`), and the median camera
:data:`CAMERA_DISTANCE` from it, as in mitnerf's own renders, so ``mitnerf video``'s default orbit frames it.

The folder written (:func:`pose_capture`)::

    DATA/images/            the photographs, copied byte for byte (the user's own are never touched)
    DATA/images_N/          with ``downscale`` N > 1: the same names box-filtered N times smaller
    DATA/transforms.json    nerfstudio's layout (camera_model OPENCV or PINHOLE, fl_x, fl_y, cx, cy, w, h, k1, k2,
                            p1, p2, per-frame OpenGL camera-to-world ``transform_matrix``, ``ply_file_path``),
                            naming images_N/ with ``downscale`` N: what ``mitnerf fit`` and nerfstudio read
    DATA/sparse/0/          the COLMAP model (binary) of images/, in the written world
    DATA/sparse_pc.ply      the sparse points (nerfstudio's ``ply_file_path``)
    DATA/mitnerf.json       near, far, each frame's depth bounds (``bounds [n, 2]``), the points' box
                            (``points_bounds``), ``layout``, and how the poses were made (``poses``)
"""

from __future__ import annotations

import contextlib
import functools
import json
import shutil
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import DataError, EnvironmentProblem
from ..settings import check, setting
from .cameras import Cameras
from .dataset import box_downscale
from .formats.capture import IMAGE_SUFFIXES, check_intrinsics, focus_point, layout, near_far
from .formats.colmap import FLIP, camera_lens, camera_pose, view_bounds
from .formats.colmap_files import read_model
from .formats.common import META, as_rgba, image_size, read_image, write_png
from .formats.transforms import camera_keys

MIN_IMAGES = 3
"""Fewest registered images a capture may have (2 to train on, every 8th held out)."""
EXHAUSTIVE_UP_TO = 100
"""``matching auto``: exhaustive up to this many images, sequential above."""
CAMERA_DISTANCE = 3.5
"""World units from the written world's origin to the median camera (mitnerf's renders' default radius)."""
CAMERA_MODELS = ("SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV")


@dataclass
class SfmConfig:
    """How ``mitnerf poses`` runs COLMAP."""

    matching: str = setting("auto", choices=("auto", "exhaustive", "sequential"), flag="--matching")
    """Image pairs matched: every pair (exhaustive), each image with its next ones in name order (sequential, for
    video frames), or auto: exhaustive up to 100 images, else sequential."""
    overlap: int = setting(10, lo=1, hi=10_000, flag="--overlap", unit="images")
    """Sequential matching: how many following images each image is matched with."""
    camera_model: str = setting("SIMPLE_RADIAL", choices=CAMERA_MODELS, flag="--camera-model")
    """COLMAP's lens model: SIMPLE_RADIAL (one focal length, one radial term: phones), OPENCV (two focal
    lengths, k1, k2, p1, p2), RADIAL, PINHOLE or SIMPLE_PINHOLE (no distortion)."""
    single_camera: bool = setting(True, flag="--single-camera")
    """One camera (intrinsics and lens) shared by all images; off: each image its own."""
    max_image_size: int = setting(1600, lo=64, hi=16384, flag="--max-image-size", unit="pixels")
    """Longest side the features are found at (larger images are shrunk for this stage only)."""
    max_features: int = setting(8192, lo=100, hi=100_000, flag="--max-features", unit="per image")
    """Most SIFT keypoints found per image (COLMAP's max_num_features; each may carry two orientations)."""
    min_registered: float = setting(0.5, lo=0, hi=1, flag="--min-registered", unit="fraction")
    """Refuse the result when fewer than this fraction of the images are registered (fewer than 3: always)."""
    downscale: int = setting(1, lo=1, hi=64, flag="--downscale")
    """Write the images N times smaller (images_N/, box-filtered) and name them in transforms.json."""
    seed: int = setting(0, lo=0, hi=2 ** 31 - 1, flag="--seed")
    """Seed of COLMAP's random sampling (RANSAC, the initial pair)."""

    def validate(self) -> None:
        check(self)


def need_pycolmap():
    """The pycolmap module, or one line that says how to install it. Its first import installs glog's crash handler
    for SIGTERM too (a stack dump, then abort): Python's own handlers for SIGINT and SIGTERM are put back, so that
    they end the command in one line."""
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        import pycolmap
    except ImportError:
        raise EnvironmentProblem("`mitnerf poses` needs pycolmap (COLMAP's algorithms): pip install -e .[poses]") \
            from None
    for sig, handler in handlers.items():
        with contextlib.suppress(ValueError, TypeError):        # not the main thread; a handler set outside Python
            signal.signal(sig, handler)
    return pycolmap


def find_images(folder: str | Path) -> list[Path]:
    """The photographs in ``folder`` (not its subfolders; hidden files skipped), in name order, each decoded once
    (a corrupt one is refused now, before any work) and all of one size; at least :data:`MIN_IMAGES`."""
    folder = Path(folder)
    if not folder.exists():
        raise DataError(f"--images {folder} does not exist; give the folder that holds your photographs")
    if not folder.is_dir():
        raise DataError(f"--images {folder} is not a folder; give the folder that holds your photographs")
    try:
        entries = sorted(folder.iterdir())
    except OSError as exc:
        raise DataError(f"cannot list {folder}: {exc.strerror}; check its permissions") from None
    files = [p for p in entries if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith(".")]
    if len(files) < MIN_IMAGES:
        others = len(entries) - len(files)
        raise DataError(f"{folder} holds {len(files)} image{'s' * (len(files) != 1)} ({', '.join(IMAGE_SUFFIXES)})"
                        f"{f' and {others} other entries' if others else ''}; structure from motion needs at least "
                        f"{MIN_IMAGES} overlapping photographs: add them")
    sizes = {}
    for p in files:
        sizes.setdefault(image_size(p), p)
    if len(sizes) > 1:
        (a, pa), (b, pb) = list(sizes.items())[:2]
        raise DataError(f"{folder}: images differ in size ({pa.name} is {a[1]} x {a[0]}, {pb.name} {b[1]} x {b[0]}); "
                        "mitnerf trains on one resolution: resize them to one size")
    for p in files:
        read_image(p)
    return files


def pose_capture(files: list[Path], out: Path, cfg: SfmConfig, log=functools.partial(print, flush=True)) -> dict:
    """Copy ``files`` (:func:`find_images`) into ``out`` (a new folder's staging folder) and write the capture there
    (module docstring); returns what mitnerf.json holds. Prints one line per stage through ``log``."""
    pycolmap = need_pycolmap()
    cfg.validate()
    t = time.perf_counter()
    images, work = out / "images", out / "sfm-work"
    images.mkdir()
    work.mkdir()
    for p in files:
        shutil.copyfile(p, images / p.name)
    names = [p.name for p in files]
    H, W = image_size(files[0])
    log(f"poses: {len(names)} images of {W} x {H} copied in {time.perf_counter() - t:.1f} s")
    models = _reconstruct(pycolmap, images, names, work, cfg, log)
    if not models:
        raise DataError(f"COLMAP could not pose {files[0].parent}: no two of its {len(names)} images share enough "
                        "features; take overlapping photographs (each spot seen from 3 or more, 10-20 degrees apart)")
    recon = max(models.values(), key=lambda r: r.num_reg_images())
    done = {recon.image(i).name for i in recon.reg_image_ids()}
    lost = [n for n in names if n not in done]
    need = max(MIN_IMAGES, int(np.ceil(cfg.min_registered * len(names))))
    if len(done) < need:
        raise DataError(f"COLMAP registered only {len(done)} of {len(names)} images (at least {need} needed; "
                        f"--min-registered {cfg.min_registered:g}); take more overlapping photographs, or try "
                        f"--matching exhaustive or another --camera-model")
    if lost:
        shown = ", ".join(lost[:20]) + (f" and {len(lost) - 20} more" if len(lost) > 20 else "")
        print(f"mitnerf: warning: {len(lost)} of {len(names)} images could not be registered and are left out: "
              f"{shown}", file=sys.stderr)
    sim = _world(pycolmap, recon)
    recon.transform(sim)
    (out / "sparse" / "0").mkdir(parents=True)
    recon.write(out / "sparse" / "0")
    recon.export_PLY(out / "sparse_pc.ply")
    shutil.rmtree(work)
    info = {"tool": f"pycolmap {pycolmap.__version__}", "camera_model": cfg.camera_model,
            "single_camera": cfg.single_camera, "matching": _matching(cfg, len(names)), "images": len(names),
            "registered": len(done), "unregistered": lost, "points": int(recon.num_points3D()),
            "reprojection_error": float(recon.compute_mean_reprojection_error()),
            "world_from_colmap": {"scale": float(sim.scale), "rotation_xyzw": np.ravel(sim.rotation.quat).tolist(),
                                  "translation": np.ravel(sim.translation).tolist()}}
    return _write_transforms(out, cfg.downscale, info, files[0].parent.name)


def _matching(cfg: SfmConfig, n: int) -> str:
    return cfg.matching if cfg.matching != "auto" else "exhaustive" if n <= EXHAUSTIVE_UP_TO else "sequential"


def _cancellable(pycolmap, fn, *args, **kwargs):
    """``fn(*args, cancellation_token=..., **kwargs)`` in a thread, so that Ctrl-C and SIGTERM (which reach only the
    main thread, between Python steps) cancel COLMAP's work and end the command at once."""
    token, result = pycolmap.CancellationToken(), {}

    def work():
        try:
            result["value"] = fn(*args, cancellation_token=token, **kwargs)
        except Exception as exc:  # noqa: BLE001 - reported by the main thread, in one line
            result["error"] = exc
    worker = threading.Thread(target=work, daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.1)
    except BaseException:
        token.cancel()
        worker.join()
        raise
    if "error" in result:
        what = " ".join(str(result["error"]).split())[:300]
        raise DataError(f"COLMAP's {fn.__name__} failed ({type(result['error']).__name__}: {what}); check the images")
    return result.get("value")


def _reconstruct(pycolmap, images: Path, names: list[str], work: Path, cfg: SfmConfig, log) -> dict:
    """COLMAP's features, matches and incremental mapping of ``images/names`` (database and models in ``work``)."""
    pycolmap.logging.minloglevel = 3                   # COLMAP's own log off (its failures raise)
    pycolmap.set_random_seed(cfg.seed)
    cpu, db = pycolmap.Device.cpu, work / "database.db"
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = cfg.camera_model
    extract = pycolmap.FeatureExtractionOptions()
    extract.max_image_size, extract.sift.max_num_features = cfg.max_image_size, cfg.max_features
    mode = pycolmap.CameraMode.SINGLE if cfg.single_camera else pycolmap.CameraMode.PER_IMAGE
    t = time.perf_counter()
    _cancellable(pycolmap, pycolmap.extract_features, db, images, image_names=names, camera_mode=mode,
                 reader_options=reader, extraction_options=extract, device=cpu)
    counts = _counts(pycolmap, db)
    log(f"poses: features: {counts['keypoints']:,} SIFT features in {counts['images']} images (at most "
        f"{cfg.max_features} each, at {cfg.max_image_size} px) in {time.perf_counter() - t:.1f} s")
    t, how = time.perf_counter(), _matching(cfg, len(names))
    if how == "exhaustive":
        _cancellable(pycolmap, pycolmap.match_exhaustive, db, device=cpu)
    else:
        pairing = pycolmap.SequentialPairingOptions()
        pairing.overlap = cfg.overlap
        _cancellable(pycolmap, pycolmap.match_sequential, db, pairing_options=pairing, device=cpu)
    counts = _counts(pycolmap, db)
    log(f"poses: matching ({how}): {counts['pairs']:,} image pairs matched, {counts['verified']:,} geometrically "
        f"verified in {time.perf_counter() - t:.1f} s")
    t = time.perf_counter()
    options = pycolmap.IncrementalPipelineOptions()
    options.random_seed, options.min_model_size = cfg.seed, MIN_IMAGES
    (work / "models").mkdir()
    models = _cancellable(pycolmap, pycolmap.incremental_mapping, db, images, work / "models", options) or {}
    best = max((r.num_reg_images() for r in models.values()), default=0)
    log(f"poses: mapping: {best} of {len(names)} images registered ({len(models)} model"
        f"{'s' * (len(models) != 1)}; the largest kept) in {time.perf_counter() - t:.1f} s")
    return models


def _counts(pycolmap, db: Path) -> dict:
    base = pycolmap.Database.open(db)
    try:
        return {"images": base.num_images(), "keypoints": base.num_keypoints(),
                "pairs": base.num_matched_image_pairs(), "verified": base.num_verified_image_pairs()}
    finally:
        base.close()


def _world(pycolmap, recon):
    """The similarity (pycolmap ``Sim3d``, new from old) to the written world (module docstring)."""
    poses = np.array([np.r_[recon.image(i).cam_from_world().inverse().matrix(), [[0, 0, 0, 1]]] @ FLIP
                      for i in sorted(recon.reg_image_ids())])          # OpenGL camera-to-world
    up = poses[:, :3, 1].mean(0)
    R = Rotation.align_vectors([[0.0, 0.0, 1.0]], [up])[0].as_matrix() if np.linalg.norm(up) > 1e-6 else np.eye(3)
    if layout(poses) == "around":
        centre = focus_point(poses)
    else:
        centre = np.median(np.array([p.xyz for p in recon.points3D.values()]), axis=0)
    scale = CAMERA_DISTANCE / max(float(np.median(np.linalg.norm(poses[:, :3, 3] - centre, axis=1))), 1e-9)
    return pycolmap.Sim3d(scale, pycolmap.Rotation3d(R), -scale * R @ centre)


def _write_transforms(out: Path, downscale: int, info: dict, scene: str) -> dict:
    """``transforms.json`` and ``mitnerf.json`` (returned) from the model in ``out/sparse/0`` (and images_N/ with
    ``downscale`` > 1)."""
    where = str(out / "sparse" / "0")
    model = read_model(out / "sparse" / "0")
    K = np.array([camera_lens(model.cameras[cid][0], model.cameras[cid][3], where) for *_, cid in model.images])
    _, W, H, _ = next(iter(model.cameras.values()))
    check_intrinsics(K[:, 0], K[:, 1], K[:, 2], K[:, 3], W, H, where)
    poses = np.array([camera_pose(q, t, name, where) for name, q, t, _ in model.images])
    cams = Cameras(poses, K[:, 0], H, W, K[:, 1], K[:, 2], K[:, 3], K[:, 4:])
    bounds = view_bounds(cams, model.points, where)
    if bounds is None:
        raise DataError(f"COLMAP's model of {scene} has no points in front of its cameras; take overlapping "
                        "photographs")
    near, far = near_far(cams, bounds)
    folder = "images"
    if downscale > 1:
        folder = f"images_{downscale}"
        (out / folder).mkdir()
        for name, *_ in model.images:
            small = box_downscale(as_rgba(read_image(out / "images" / name))[None, ..., :3], downscale, downscale)
            write_png(out / folder / name, small[0])
        cams = cams.downscaled(downscale)
    header, own = camera_keys(cams)
    header.update(ply_file_path="sparse_pc.ply", frames=[
        {"file_path": f"{folder}/{name}", "transform_matrix": cams.poses[i].tolist(), **own[i]}
        for i, (name, *_) in enumerate(model.images)])
    (out / "transforms.json").write_text(json.dumps(header, indent=1))
    meta = {"format": "nerfstudio", "scene": scene, "near": near, "far": far, "bounds": bounds.tolist(),
            "points_bounds": np.percentile(model.points, [0.1, 99.9], axis=0).tolist(), "layout": layout(poses),
            "poses": info}
    (out / META).write_text(json.dumps(meta, indent=1))
    return meta
