"""Reading hostile files: every value is checked before it is used, every failure is one
:class:`~mitnerf.errors.DataError` line that names the file, the problem and the fix.

Numbers must be real (``true`` is not a focal length), finite and plausible; poses rigid (rotation
orthonormal with determinant +1, bottom row ``0 ... 0 1``); images are refused from their header
(corrupt, truncated, over ``MAX_SIDE`` pixels a side, or too large for memory) before they are
decoded; arrays are never unpickled.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import warnings
import zipfile
from pathlib import Path

import numpy as np

from ..._io import available_memory
from ...errors import DataError
from ..color import to_uint8

META = "mitnerf.json"
MAX_SIDE = 16384
"""Largest image side mitnerf accepts (pixels)."""
BYTES_PER_PIXEL = 40
"""Memory a pixel costs while its views are read (decoded to floats before their 8 bits are kept, with a margin);
training holds the 8 bits and makes rays per batch (:mod:`mitnerf.data.rays`)."""
_TYPES = {dict: "an object", list: "a list", str: "a string", (int, float): "a number"}


def read_file(path: Path, fix: str = "", binary: bool = False) -> str | bytes:
    """A file's UTF-8 text (``fix``: what to do with one that is not UTF-8), or its bytes; one line where it cannot
    be read."""
    try:
        return path.read_bytes() if binary else path.read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"cannot read {path}: {exc.strerror}; check the path and its permissions") from None
    except UnicodeDecodeError:
        raise DataError(f"{path} is not UTF-8 text; {fix}") from None


def read_json(path: Path) -> dict:
    path = Path(path)
    try:
        data = json.loads(read_file(path, "fix or regenerate it"))
    except json.JSONDecodeError as exc:
        raise DataError(f"{path} is not valid JSON ({exc.msg} at line {exc.lineno}); fix or regenerate it") from None
    except RecursionError:
        raise DataError(f"{path} nests too deeply to be a dataset file; fix or regenerate it") from None
    if not isinstance(data, dict):
        raise DataError(f"{path} must hold a JSON object, got {type(data).__name__}; fix or regenerate it")
    return data


def get(obj: dict, key: str, kind: type, where: str, default=...):
    """``obj[key]`` if it is of ``kind``; a missing key is an error unless ``default`` is given."""
    if key not in obj:
        if default is not ...:
            return default
        raise DataError(f"{where} lacks {key!r}; add it")
    value = obj[key]
    if not isinstance(value, kind):
        raise DataError(f"{where}: {key!r} must be {_TYPES.get(kind) or getattr(kind, '__name__', kind)}, "
                        f"got {json.dumps(value)[:40]}; fix the file")
    return value


def number(value, what: str, lo: float | None = None, hi: float | None = None, strict_lo: bool = True) -> float:
    """A real number (not a bool, not a string), finite, within ``(lo, hi]``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise DataError(f"{what} must be a number, got {json.dumps(value, default=str)[:40]}; fix the file")
    v = float(value)
    if not math.isfinite(v):
        raise DataError(f"{what} must be finite, got {v}; fix the file")
    if lo is not None and (v <= lo if strict_lo else v < lo):
        raise DataError(f"{what} must be {'>' if strict_lo else '>='} {lo:g}, got {v:g}; fix the file")
    if hi is not None and v > hi:
        raise DataError(f"{what} = {v:g} is implausibly large (at most {hi:g}); check its unit")
    return v


def integer(value, what: str, lo: int = 1, hi: int = MAX_SIDE) -> int:
    v = number(value, what, lo, hi, strict_lo=False)
    if not v.is_integer():
        raise DataError(f"{what} must be a whole number, got {v:g}; fix the file")
    return int(v)


def read_poses(frames: list, size: int, where: str) -> np.ndarray:
    """Every frame's ``transform_matrix`` (lists of numbers, so every frame is a dict), checked: ``[n, size, size]``."""
    out, key = np.empty((len(frames), size, size)), "transform_matrix"
    for i, f in enumerate(frames):
        m = f.get(key) if isinstance(f, dict) else None
        try:        # lists of real numbers only: not "0.5", true or null (numpy would convert them)
            if not isinstance(m, list) or not all(isinstance(row, list) and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in row) for row in m):
                raise TypeError
            a = np.array(m, dtype=np.float64)
        except (TypeError, ValueError):
            raise DataError(f"{where}: frame {i} needs {key!r} as a {size}x{size} list of numbers") from None
        if a.shape != (size, size):
            raise DataError(f"{where}: frame {i} has a {key!r} of shape {a.shape}, expected ({size}, {size})")
        out[i] = a
    check_poses(out, where)
    return out


def check_poses(poses: np.ndarray, where: str) -> None:
    """Camera-to-world matrices ``[n, k+1, k+1]``: finite, a proper rotation, ``0 .. 0 1`` below."""
    k = poses.shape[-1] - 1
    for i, P in enumerate(poses):
        if not np.isfinite(P).all():
            raise DataError(f"{where}: pose {i} contains NaN or infinity; fix or drop that frame")
        R = P[:k, :k]
        err = float(np.abs(R.T @ R - np.eye(k)).max())
        if err > 1e-3:
            raise DataError(f"{where}: the rotation of pose {i} is not orthonormal (|R^T R - I| = {err:.3g}: "
                            "scaled, sheared or degenerate); give rigid camera-to-world matrices")
        if np.linalg.det(R) < 0:
            raise DataError(f"{where}: pose {i} is a mirror image (determinant -1); give a proper rotation")
        if np.abs(P[k, :k]).max() > 1e-6 or abs(P[k, k] - 1) > 1e-6:
            raise DataError(f"{where}: pose {i}'s last row must be 0 ... 0 1")
        if np.abs(P[:k, k]).max() > 1e6:
            raise DataError(f"{where}: pose {i} stands {np.abs(P[:k, k]).max():.3g} units away; check the units")


def check_focal(focal: float, pixels: int, where: str) -> float:
    """A focal length in pixels for an image ``pixels`` wide: a field of view in (0.05, 179) degrees."""
    f = number(focal, f"{where}: the focal length", 0)
    fov = math.degrees(2 * math.atan(pixels / (2 * f)))
    if not 0.05 < fov < 179:
        raise DataError(f"{where}: focal length {f:g} px gives a {fov:.3g} degree field of view at {pixels} px; "
                        "check the focal length and its unit (pixels)")
    return f


@contextlib.contextmanager
def _own_size_limits():
    """PIL's decompression-bomb check off: mitnerf refuses oversized views itself, with their size."""
    from PIL import Image

    old = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            yield
    finally:
        Image.MAX_IMAGE_PIXELS = old


def image_size(path: Path) -> tuple[int, int]:
    """``(H, W)`` from the image header, without decoding it; refuses oversized views."""
    from PIL import Image

    try:
        with _own_size_limits(), Image.open(path) as im:
            w, h = im.size
    except FileNotFoundError:
        raise DataError(f"image {path} is missing; every frame needs its image") from None
    except Exception as exc:  # noqa: BLE001 - PIL raises many types for corrupt headers
        raise DataError(f"cannot read image {path} ({type(exc).__name__}); replace the file") from None
    if max(w, h) > MAX_SIDE or min(w, h) < 1:
        raise DataError(f"image {path} is {w} x {h} pixels; mitnerf takes views of 1 to {MAX_SIDE} pixels per side: "
                        "downsample it")
    return h, w


def view_size(paths: list[Path], where: str, downscale: int = 1) -> tuple[int, int]:
    """``(H, W)`` that every image of ``paths`` has, from their headers; refused when they differ, or when the views
    box-filtered by ``downscale`` (a view one pixel wide, 2D, keeps its column) have no pixel or do not fit in
    memory (:func:`check_memory`)."""
    sizes = {image_size(p) for p in paths}
    if len(sizes) != 1:
        raise DataError(f"{where}: images differ in size {sorted(sizes)[:3]}; all views need one resolution: "
                        "resize them")
    H, W = sizes.pop()
    h, w = H // downscale, W // (1 if W == 1 else downscale)
    if min(h, w) < 1:
        raise DataError(f"{where}: downscale {downscale} leaves no pixel of {W} x {H} views; choose a smaller one")
    check_memory(len(paths) * h * w, where)
    return H, W


def read_image(path: Path) -> np.ndarray:
    """An 8- or 16-bit image as float32 in [0, 1], ``[H, W]`` or ``[H, W, C]``."""
    import imageio.v3 as iio

    from PIL import Image

    image_size(path)
    try:
        with _own_size_limits():
            with Image.open(path) as im:
                im.verify()            # every chunk's checksum and the end of the file: a cut PNG is refused
                png = im.format == "PNG"
            if png:                    # verify() stops at the end chunk's name: check that all of it is there
                with open(path, "rb") as f:
                    f.seek(max(0, os.fstat(f.fileno()).st_size - 4096))
                    if b"\x00\x00\x00\x00IEND\xaeB`\x82" not in f.read():       # the empty IEND chunk that ends a PNG
                        raise EOFError("no end chunk")
            img = iio.imread(path)
    except Exception as exc:  # noqa: BLE001 - imageio raises many types for corrupt files
        raise DataError(f"cannot decode image {path} ({type(exc).__name__}: truncated or corrupt); "
                        "replace the file") from None
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[-1] not in (1, 2, 3, 4)):
        raise DataError(f"image {path} has shape {img.shape}; expected grey, RGB or RGBA")
    if img.dtype.kind not in "uif":
        raise DataError(f"image {path} holds {img.dtype} pixels; save it as 8- or 16-bit PNG")
    scale = 65535.0 if img.dtype == np.uint16 else 255.0 if img.dtype == np.uint8 else 1.0
    out = img.astype(np.float32) / scale
    if not np.isfinite(out).all():
        raise DataError(f"image {path} contains NaN or infinite pixels; replace the file")
    return out


def read_view(path: Path, size: tuple[int, int], what: str = "") -> np.ndarray:
    """:func:`read_image` of an image that must be ``size`` ``(H, W)``: ``what`` it is (``a mask``) where that is a
    rule (it needs the size of its view), else the size its header gave a moment before (refused as changed)."""
    H, W = size
    h, w = image_size(path) if what else size
    if (h, w) != (H, W):
        raise DataError(f"{path} is {w} x {h} pixels but its view is {W} x {H}; {what} needs the size of its view")
    img = read_image(path)
    if img.shape[:2] != (H, W):
        raise DataError(f"{path} is now {img.shape[1]} x {img.shape[0]} pixels, not the {W} x {H} its header said a "
                        "moment ago: it changed while it was read; run again once it is written")
    return img


def write_png(path: Path, image: np.ndarray) -> None:
    """``image`` (floats in [0, 1], or a mask) as an 8-bit PNG, what :func:`read_image` reads back."""
    import imageio.v3 as iio

    iio.imwrite(path, to_uint8(image))


def as_rgba(img: np.ndarray) -> np.ndarray:
    """Grey / grey+alpha / RGB / RGBA -> ``[H, W, 4]`` (alpha 1 where there is none)."""
    if img.ndim == 2:
        img = img[..., None]
    c = img.shape[-1]
    rgb = np.repeat(img[..., :1], 3, -1) if c in (1, 2) else img[..., :3]
    alpha = img[..., -1:] if c in (2, 4) else np.ones(img.shape[:2] + (1,), np.float32)
    return np.concatenate([rgb, alpha], -1).astype(np.float32)


@contextlib.contextmanager
def _array_file(path: Path, where: str | None = None, missing: str = "restore it or drop the frame"):
    """An array file's read, whose failure is one line: the file is missing, or truncated or corrupt."""
    try:
        yield
    except FileNotFoundError:
        raise DataError(f"{path} is missing; {missing}") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError, SyntaxError, TypeError) as exc:
        raise DataError(f"{where or path} is truncated or corrupt ({type(exc).__name__}); replace the file") from None


def read_npz(path: Path, where: str | None = None, keys: list[str] | None = None) -> dict[str, np.ndarray]:
    """The arrays ``keys`` (all if None) of an ``.npz`` file, never unpickled."""
    with _array_file(path, where), np.load(path, allow_pickle=False) as z:
        return {k: np.asarray(z[k]) for k in (z.files if keys is None else keys)}


def _array_header(f) -> tuple[tuple, np.dtype]:
    version = np.lib.format.read_magic(f)
    read = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    if version not in read:
        raise ValueError(f"npy format {version}")
    shape, _, dtype = read[version](f)
    return shape, dtype


def npz_shapes(path: Path) -> dict[str, tuple[tuple, np.dtype]]:
    """``{name: (shape, dtype)}`` of the arrays of an ``.npz`` file, from their headers only
    (nothing is loaded: a file that claims huge arrays is refused before it fills memory)."""
    with _array_file(path), zipfile.ZipFile(path) as z:
        out = {}
        for info in (i for i in z.infolist() if i.filename.endswith(".npy")):
            with z.open(info) as f:
                out[info.filename[:-4]] = _array_header(f)
        return out


def npy_shape(path: Path) -> tuple[tuple, np.dtype]:
    """``(shape, dtype)`` of an ``.npy`` file from its header alone (a file that claims a huge array is refused
    before it fills memory)."""
    with _array_file(path, missing="restore it"), open(path, "rb") as f:
        return _array_header(f)


def read_npy(path: Path, shape: tuple, where: str, dtype=np.float32) -> np.ndarray:
    """A float array of ``shape`` (as ``dtype``) from an ``.npy`` file, never unpickled."""
    with _array_file(path):
        a = np.load(path, allow_pickle=False)
    if not isinstance(a, np.ndarray) or a.dtype.kind not in "uif" or a.size != int(np.prod(shape)):
        raise DataError(f"{where}: {path.name} holds {getattr(a, 'shape', '?')} {getattr(a, 'dtype', '')} values, "
                        f"expected {shape} numbers; regenerate the file")
    a = a.astype(dtype).reshape(shape)
    if not np.isfinite(a).all():
        raise DataError(f"{where}: {path.name} contains NaN or infinity; regenerate the file")
    return a


def all_or_none(have: list[bool], names: list, where: str, what: str) -> bool:
    """Whether every view has ``what`` (``have[i]``: view ``names[i]`` has it); refused when only some have it."""
    if any(have) and not all(have):
        raise DataError(f"{where}: {names[have.index(False)]} has no {what} while other views have theirs; restore "
                        "it, or remove it from every view")
    return all(have)


def check_memory(n_pixels: int, where: str) -> None:
    """Refuse, before loading, a dataset whose pixels would not fit in the machine's memory."""
    need = n_pixels * BYTES_PER_PIXEL
    avail = available_memory()
    if avail is not None and need > avail:
        raise DataError(f"{where} has {n_pixels:,} pixels, which need about {need / 2**30:.1f} GiB to read; "
                        f"this machine has {avail / 2**30:.1f} GiB free: read them smaller (--downscale) or use fewer "
                        "views")


CAPTURE_KEYS = ("path", "bounds", "points_bounds", "scale_mat")
"""What a reader records about the files it read, which a written dataset's files replace."""


def write_meta(folder: Path, dataset, fmt: str) -> None:
    meta = {k: v for k, v in dataset.meta.items() if k not in CAPTURE_KEYS}
    meta.update(format=fmt, near=dataset.near, far=dataset.far, splits={k: len(v) for k, v in dataset.splits.items()})
    (folder / META).write_text(json.dumps(meta, indent=1))


def read_meta(folder: Path, fmt: str | None = None, downscale: int = 1) -> dict:
    """Our provenance file, when there is one (checked like any input), with the ``format`` ``fmt`` where it names
    none and the ``downscale`` the views are read at (when > 1)."""
    path = Path(folder) / META
    meta = read_json(path) if path.exists() else {}
    for key in ("near", "far"):
        if key in meta:
            number(meta[key], f"{path}: {key!r}", 0, 1e6, strict_lo=False)
    if "near" in meta and "far" in meta and not meta["near"] < meta["far"]:
        raise DataError(f"{path}: near ({meta['near']}) must be smaller than far ({meta['far']}); fix the file")
    if "polygon" in meta:
        try:
            assert all(isinstance(p, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in p)
                       for p in meta["polygon"])             # numbers, not "0.5" (numpy would convert it)
            pts = np.asarray(meta["polygon"], np.float64)
            assert pts.ndim == 2 and pts.shape[1] == 2 and len(pts) >= 3 and np.isfinite(pts).all()
        except (TypeError, ValueError, AssertionError):
            raise DataError(f"{path}: 'polygon' must be a list of [x, y] points; fix or delete the key") from None
    for key in ("scene", "kind", "format", "mesh", "texture"):
        if key in meta and not isinstance(meta[key], str):
            raise DataError(f"{path}: {key!r} must be a string, got {json.dumps(meta[key], default=str)[:40]}; "
                            "fix or delete the key")
    bg = meta.get("background", [0, 0, 0])
    if not (isinstance(bg, list) and len(bg) == 3):
        raise DataError(f"{path}: 'background' must be [r, g, b]; fix or delete the key")
    for v in bg:
        number(v, f"{path}: a background value", 0, 1, strict_lo=False)
    if fmt:
        meta.setdefault("format", fmt)
    if downscale > 1:
        meta["downscale"] = downscale
    return meta
