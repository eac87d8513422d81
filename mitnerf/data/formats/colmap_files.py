"""COLMAP's sparse model files, text and binary: ``cameras``, ``images`` and ``points3D`` (``.txt`` / ``.bin``),
read into plain arrays and written back. Every count is checked against the file's size before anything is
allocated; every failure is one :class:`~mitnerf.errors.DataError` line naming the file and the record.

Text, one record per line after ``#`` comments::

    cameras.txt    CAMERA_ID MODEL WIDTH HEIGHT PARAMS...
    images.txt     IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME
                   X Y POINT3D_ID ...                       (the image's 2D points; may be empty)
    points3D.txt   POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)...

Binary, little-endian: ``cameras.bin`` u64 count, then (i32 id, i32 model id, u64 width, u64 height, f64
params...); ``images.bin`` u64 count, then (i32 id, f64 qvec[4], f64 tvec[3], i32 camera id, NAME NUL, u64 n,
n x (f64 x, f64 y, i64 point id)); ``points3D.bin`` u64 count, then (u64 id, f64 xyz[3], u8 rgb[3], f64 error,
u64 n, n x (i32 image id, i32 point index)).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import DataError
from .capture import MAX_VIEWS
from .common import integer, read_file

MODEL_IDS = {0: ("SIMPLE_PINHOLE", 3), 1: ("PINHOLE", 4), 2: ("SIMPLE_RADIAL", 4), 3: ("RADIAL", 5),
             4: ("OPENCV", 8), 5: ("OPENCV_FISHEYE", 8), 6: ("FULL_OPENCV", 12), 7: ("FOV", 5),
             8: ("SIMPLE_RADIAL_FISHEYE", 4), 9: ("RADIAL_FISHEYE", 5), 10: ("THIN_PRISM_FISHEYE", 12)}
"""COLMAP's camera models: id -> (name, number of parameters)."""
PARAMS = {name: n for name, n in MODEL_IDS.values()}
MAX_POINTS = 50_000_000


@dataclass
class Model:
    """A sparse model: cameras by id, images (sorted by name) and the 3D points."""

    cameras: dict[int, tuple[str, int, int, np.ndarray]]
    """id -> (model name, width, height, parameters)."""
    images: list[tuple[str, np.ndarray, np.ndarray, int]]
    """(name, qvec [4] (w, x, y, z), tvec [3], camera id): world-to-camera in OpenCV axes."""
    points: np.ndarray
    """``[P, 3]`` world positions."""


def read_model(folder: Path) -> Model:
    """The model in ``folder``: binary when all three ``.bin`` files exist, else text (``points3D`` may be absent)."""
    binary = all((folder / f"{n}.bin").is_file() for n in ("cameras", "images", "points3D"))
    ext = ".bin" if binary else ".txt"
    for name in ("cameras", "images"):
        if not (folder / f"{name}{ext}").is_file():
            raise DataError(f"{folder} has no {name}.txt (nor all three .bin files); export the model with "
                            "`colmap model_converter` or point at the folder that holds it")
    read = (_Binary if binary else _Text)
    cameras = read(folder / f"cameras{ext}").cameras()
    images = read(folder / f"images{ext}").images()
    pts = folder / f"points3D{ext}"
    points = read(pts).points() if pts.is_file() else np.zeros((0, 3))
    return Model(cameras, sorted(images, key=lambda im: im[0]), points)


class _Text:
    def __init__(self, path: Path):
        self.path, self.lines = path, read_file(path, "export the model again").splitlines()

    def _rows(self):
        return [(i + 1, line) for i, line in enumerate(self.lines) if not line.lstrip().startswith("#")]

    def _numbers(self, tokens: list[str], line: int, kind=float) -> list:
        try:
            return [kind(t) for t in tokens]
        except ValueError:
            raise DataError(f"{self.path}, line {line}: expected numbers, got {' '.join(tokens)[:60]!r}; "
                            "fix the line or export the model again") from None

    def cameras(self) -> dict:
        out = {}
        for line, text in self._rows():
            t = text.split()
            if not t:
                continue
            if len(t) < 4:
                raise DataError(f"{self.path}, line {line}: a camera needs CAMERA_ID MODEL WIDTH HEIGHT PARAMS")
            cid, w, h = self._numbers([t[0], t[2], t[3]], line, int)
            _add_camera(out, cid, t[1], w, h, np.array(self._numbers(t[4:], line)), f"{self.path}, line {line}")
        return out

    def images(self) -> list:
        out, rows, k = [], self._rows(), 0
        while k < len(rows):
            line, text = rows[k]
            t = text.split(maxsplit=9)
            k += 1
            if not t:
                continue
            if len(t) < 10:
                raise DataError(f"{self.path}, line {line}: an image needs IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID "
                                "NAME")
            v = self._numbers(t[1:8], line)
            pts = rows[k][1].split() if k < len(rows) else []
            if len(pts) % 3:
                raise DataError(f"{self.path}, line {line + 1}: 2D points come as X Y POINT3D_ID triples")
            self._numbers(pts, line + 1)
            k += 1
            out.append((t[9].strip(), np.array(v[:4]), np.array(v[4:]), self._numbers([t[8]], line, int)[0]))
        return out

    def points(self) -> np.ndarray:
        rows = [(line, text.split()) for line, text in self._rows() if text.strip()]
        out = np.empty((len(rows), 3))
        for j, (line, t) in enumerate(rows):
            if len(t) < 8 or len(t) % 2:
                raise DataError(f"{self.path}, line {line}: a point needs POINT3D_ID X Y Z R G B ERROR and "
                                "(IMAGE_ID POINT2D_IDX) pairs")
            out[j] = self._numbers(t[1:4], line)
        return out


class _Binary:
    def __init__(self, path: Path):
        self.path, self.data, self.at = path, read_file(path, binary=True), 0

    def take(self, fmt: str) -> tuple:
        size = struct.calcsize("<" + fmt)
        if self.at + size > len(self.data):
            raise DataError(f"{self.path} is truncated (record at byte {self.at}); export the model again")
        out = struct.unpack_from("<" + fmt, self.data, self.at)
        self.at += size
        return out

    def end(self, out):
        """``out``, once every byte of the file has been read."""
        if self.at != len(self.data):
            raise DataError(f"{self.path} holds {len(self.data) - self.at} bytes after its last record; export the "
                            "model again")
        return out

    def count(self, least: int, limit: int, what: str) -> int:
        """A record count that the rest of the file can hold (``least`` bytes each) and at most ``limit``."""
        n = self.take("Q")[0]
        if n > limit or n * least > len(self.data) - self.at:
            raise DataError(f"{self.path} claims {n:,} {what}, more than the file holds; export the model again")
        return n

    def cameras(self) -> dict:
        out = {}
        for _ in range(self.count(24, MAX_VIEWS, "cameras")):
            cid, model, w, h = self.take("iiQQ")
            if model not in MODEL_IDS:
                raise DataError(f"{self.path}: camera {cid} has model id {model}, which COLMAP does not define; "
                                "export the model again")
            name, n = MODEL_IDS[model]
            _add_camera(out, cid, name, w, h, np.array(self.take(f"{n}d")), str(self.path))
        return self.end(out)

    def images(self) -> list:
        out = []
        for _ in range(self.count(73, MAX_VIEWS, "images")):
            v = self.take("i7di")
            end = self.data.find(b"\0", self.at)
            if end < 0:
                raise DataError(f"{self.path} is truncated (an image name has no end); export the model again")
            try:
                name = self.data[self.at:end].decode("utf-8")
            except UnicodeDecodeError:
                raise DataError(f"{self.path}: an image name is not UTF-8; export the model again") from None
            self.at = end + 1
            n = self.count(24, MAX_POINTS, "2D points")
            self.at += 24 * n
            out.append((name, np.array(v[1:5]), np.array(v[5:8]), v[8]))
        return self.end(out)

    def points(self) -> np.ndarray:
        n = self.count(51, MAX_POINTS, "3D points")
        out = np.empty((n, 3))
        for j in range(n):
            out[j] = self.take("Q3d3Bd")[1:4]
            track = self.count(8, MAX_VIEWS * 1000, "track elements")
            self.at += 8 * track
        return self.end(out)


def _add_camera(out: dict, cid: int, model: str, w: int, h: int, params: np.ndarray, where: str) -> None:
    if cid in out:
        raise DataError(f"{where}: camera {cid} is defined twice; export the model again")
    w, h = integer(w, f"{where}: camera {cid}'s width"), integer(h, f"{where}: camera {cid}'s height")
    if model in PARAMS and len(params) != PARAMS[model]:
        raise DataError(f"{where}: a {model} camera has {PARAMS[model]} parameters, camera {cid} has {len(params)}")
    out[cid] = (model, w, h, params)


def write_model(folder: Path, model: Model, binary: bool = False, tracks: list | None = None) -> None:
    """Write ``model`` into ``folder``; ``tracks[i]``: point ``i``'s ``(image index, x, y)`` (one observation)."""
    folder.mkdir(parents=True)
    ids = {name: i for i, (name, _) in MODEL_IDS.items()}
    obs, index = [[] for _ in model.images], []           # per image: (x, y, point id); per point: its place there
    for j, (i, x, y) in enumerate(tracks or []):
        index.append(len(obs[i]))
        obs[i].append((x, y, j + 1))
    if binary:
        b = [struct.pack("<Q", len(model.cameras))]
        for cid, (name, w, h, p) in model.cameras.items():
            b.append(struct.pack(f"<iiQQ{len(p)}d", cid, ids[name], w, h, *p))
        (folder / "cameras.bin").write_bytes(b"".join(b))
        b = [struct.pack("<Q", len(model.images))]
        for i, (name, q, t, cid) in enumerate(model.images):
            b.append(struct.pack("<i7di", i + 1, *q, *t, cid) + name.encode() + b"\0" + struct.pack("<Q", len(obs[i])))
            b += [struct.pack("<ddq", *o) for o in obs[i]]
        (folder / "images.bin").write_bytes(b"".join(b))
        b = [struct.pack("<Q", len(model.points))]
        for j, x in enumerate(model.points):
            b.append(struct.pack("<Q3d3BdQii", j + 1, *x, 128, 128, 128, 0.0, 1, tracks[j][0] + 1, index[j]))
        (folder / "points3D.bin").write_bytes(b"".join(b))
        return
    fmt = lambda values: " ".join(repr(float(v)) for v in values)
    (folder / "cameras.txt").write_text("# Camera list: CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n" + "".join(
        f"{cid} {name} {w} {h} {fmt(p)}\n" for cid, (name, w, h, p) in model.cameras.items()))
    (folder / "images.txt").write_text(
        "# Image list with two lines per image: IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME / "
        "POINTS2D[] as (X, Y, POINT3D_ID)\n" + "".join(
            f"{i + 1} {fmt(q)} {fmt(t)} {cid} {name}\n" + " ".join(f"{fmt(o[:2])} {o[2]}" for o in obs[i]) + "\n"
            for i, (name, q, t, cid) in enumerate(model.images)))
    (folder / "points3D.txt").write_text(
        "# 3D point list: POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n" + "".join(
            f"{j + 1} {fmt(x)} 128 128 128 0.0 {tracks[j][0] + 1} {index[j]}\n" for j, x in enumerate(model.points)))
