"""Meshes as files: a binary PLY writer and reader (positions, faces, optional per-vertex colour and UV),
:func:`normalise` into the unit sphere, :func:`grid_faces`. Mitsuba reads float ``r, g, b`` properties as the
``vertex_color`` attribute and ``u, v`` as texture coordinates; VTK/pyvista read the same file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._io import atomic_write_bytes

PROPERTIES = (("vertices", "xyz"), ("uv", "uv"), ("colors", "rgb"))
"""The arrays of a mesh and their float vertex properties, in file order."""


def write_ply(path: str | Path, vertices: np.ndarray, faces: np.ndarray,
              colors: np.ndarray | None = None, uv: np.ndarray | None = None) -> Path:
    """Write a triangle mesh. ``vertices [v, 3]``, ``faces [f, 3]``, ``colors [v, 3]``, ``uv [v, 2]``."""
    arrays = {"vertices": vertices, "uv": uv, "colors": colors}
    cols = [(n, arrays[key][:, k]) for key, props in PROPERTIES if arrays[key] is not None for k, n in enumerate(props)]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}"]
    header += [f"property float {name}" for name, _ in cols]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    vdata = np.stack([c for _, c in cols], axis=1).astype("<f4")
    fdata = np.empty(len(faces), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    fdata["n"], fdata["idx"] = 3, faces
    payload = ("\n".join(header) + "\n").encode() + vdata.tobytes() + fdata.tobytes()
    return atomic_write_bytes(Path(path), payload)


def read_ply(path: str | Path) -> dict[str, np.ndarray]:
    """Read back what :func:`write_ply` wrote: ``vertices``, ``faces`` and, when present, ``colors`` and ``uv``."""
    raw = Path(path).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    lines = raw[:end].decode().splitlines()
    if "format binary_little_endian 1.0" not in lines:
        raise ValueError(f"{path}: only binary little-endian PLY files written by mitnerf are supported")
    words = [line.split() for line in lines]
    n_vert, n_face = (next((int(w[2]) for w in words if w[:2] == ["element", el]), 0) for el in ("vertex", "face"))
    names = [w[2] for w in words if w[:2] == ["property", "float"]]
    vdata = np.frombuffer(raw, "<f4", n_vert * len(names), end).reshape(n_vert, len(names))
    fdata = np.frombuffer(raw, [("n", "u1"), ("idx", "<i4", (3,))], n_face, end + vdata.nbytes)
    col = {name: vdata[:, k] for k, name in enumerate(names)}
    out = {key: np.stack([col[n] for n in props], 1) for key, props in PROPERTIES if props[0] in col}
    return {**out, "faces": fdata["idx"].copy()}


def normalise(vertices: np.ndarray, up_axis: int) -> np.ndarray:
    """Rotate ``up_axis`` onto +z, centre the bounding box, scale into the unit sphere."""
    v = np.asarray(vertices, dtype=np.float64)
    if up_axis == 1:      # (x, y, z) -> (x, -z, y): a proper rotation about x
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)
    elif up_axis != 2:
        raise ValueError(f"up_axis must be 1 (y) or 2 (z), got {up_axis}")
    v = v - (v.max(0) + v.min(0)) / 2
    return v / np.linalg.norm(v, axis=1).max() * 0.95


def grid_faces(rows: int, cols: int) -> np.ndarray:
    """Two triangles per cell of a row-major ``(rows + 1) x (cols + 1)`` vertex grid, ``[2 rows cols, 3]``."""
    i, j = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = (i * (cols + 1) + j).ravel()
    return np.concatenate([np.stack([a, a + 1, a + cols + 2], 1), np.stack([a, a + cols + 2, a + cols + 1], 1)])
