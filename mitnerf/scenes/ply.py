"""Meshes as files: a small binary PLY writer and reader (positions, faces, optional per-vertex
colour and UV), and :func:`normalise`, which puts a mesh into the unit sphere.

Mitsuba's PLY loader turns float ``r, g, b`` properties into the ``vertex_color``
attribute and ``u, v`` into texture coordinates; VTK/pyvista read the same file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._io import atomic_write_bytes


def write_ply(path: str | Path, vertices: np.ndarray, faces: np.ndarray,
              colors: np.ndarray | None = None, uv: np.ndarray | None = None) -> Path:
    """Write a triangle mesh. ``vertices [v, 3]``, ``faces [f, 3]``, ``colors [v, 3]``, ``uv [v, 2]``."""
    cols = [("x", vertices[:, 0]), ("y", vertices[:, 1]), ("z", vertices[:, 2])]
    if uv is not None:
        cols += [("u", uv[:, 0]), ("v", uv[:, 1])]
    if colors is not None:
        cols += [("r", colors[:, 0]), ("g", colors[:, 1]), ("b", colors[:, 2])]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}"]
    header += [f"property float {name}" for name, _ in cols]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    vdata = np.stack([c for _, c in cols], axis=1).astype("<f4")
    fdata = np.empty(len(faces), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    fdata["n"], fdata["idx"] = 3, faces
    payload = ("\n".join(header) + "\n").encode() + vdata.tobytes() + fdata.tobytes()
    return atomic_write_bytes(Path(path), payload)


def read_ply(path: str | Path) -> dict[str, np.ndarray]:
    """Read back what :func:`write_ply` wrote: ``vertices``, ``faces`` and, when
    present, ``colors`` and ``uv``."""
    raw = Path(path).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    lines = raw[:end].decode().splitlines()
    if "format binary_little_endian 1.0" not in lines:
        raise ValueError(f"{path}: only binary little-endian PLY files written by mitnerf are supported")
    n_vert = n_face = 0
    names = []
    for line in lines:
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            n_vert = int(parts[2])
        elif parts[:2] == ["element", "face"]:
            n_face = int(parts[2])
        elif parts[:2] == ["property", "float"]:
            names.append(parts[2])
    vdata = np.frombuffer(raw, "<f4", n_vert * len(names), end).reshape(n_vert, len(names))
    fdata = np.frombuffer(raw, [("n", "u1"), ("idx", "<i4", (3,))], n_face, end + vdata.nbytes)
    col = {name: vdata[:, k] for k, name in enumerate(names)}
    out = {"vertices": np.stack([col["x"], col["y"], col["z"]], 1), "faces": fdata["idx"].copy()}
    if "r" in col:
        out["colors"] = np.stack([col["r"], col["g"], col["b"]], 1)
    if "u" in col:
        out["uv"] = np.stack([col["u"], col["v"]], 1)
    return out


def normalise(vertices: np.ndarray, up_axis: int) -> np.ndarray:
    """Rotate ``up_axis`` onto +z, centre the bounding box, scale into the unit sphere."""
    v = np.asarray(vertices, dtype=np.float64)
    if up_axis == 1:      # (x, y, z) -> (x, -z, y): a proper rotation about x
        v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)
    elif up_axis != 2:
        raise ValueError(f"up_axis must be 1 (y) or 2 (z), got {up_axis}")
    v = v - (v.max(0) + v.min(0)) / 2
    return v / np.linalg.norm(v, axis=1).max() * 0.95
