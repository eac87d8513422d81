"""3D objects for the window-shopping experiments: product-like meshes, textured.

* ``ant``, ``airplane``, ``nut``: the meshes that ship inside the pyvista wheel,
  turned z-up, centred, scaled into the unit sphere, subdivided, and painted with a
  procedural 3D colour pattern baked into per-vertex colours (they carry no UVs).
* ``vase``: a procedural surface of revolution with UVs and a painted image texture,
  the stand-in for a few-photo product shot.
* ``brick``: a Lego-like toy bulldozer with a texture atlas of fine prints
  (:mod:`mitnerf.scenes.brick`), the stand-in for tiny-NeRF's Lego.

Each builder writes its assets (PLY, PNG) and returns them as XML ``$variables``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._io import atomic_write_bytes
from .brick import brick_mesh
from .ply import normalise, write_ply

# name -> (pyvista loader, up axis of the raw mesh, stripe direction, hue offset)
PYVISTA_OBJECTS = {
    "ant": ("load_ant", 1, (0.3, 0.9, 0.3), 0.0),
    "airplane": ("load_airplane", 2, (1.0, 0.2, 0.4), 0.35),
    "nut": ("load_nut", 1, (0.2, 0.3, 1.0), 0.7),
}


def pattern_color(p: np.ndarray, stripe_dir, hue: float) -> np.ndarray:
    """A procedural 3D texture: a hue ramp up the object, crossed by soft stripes and
    a finer checker, so that fields need real spatial frequency to fit it. ``[v, 3]``."""
    a = np.asarray(stripe_dir, float)
    a /= np.linalg.norm(a)
    ramp = 0.5 + 0.5 * p[:, 2]
    phase = np.array([0.0, 1.0 / 3.0, 2.0 / 3.0])
    base = 0.5 + 0.3 * np.cos(2 * np.pi * (0.6 * ramp[:, None] + hue + phase))
    stripes = 0.5 + 0.5 * np.sin(2 * np.pi * 4.0 * (p @ a))
    checker = np.sign(np.sin(9 * p[:, 0]) * np.sin(9 * p[:, 1]) * np.sin(9 * p[:, 2]))
    col = base * (0.55 + 0.45 * stripes[:, None]) + 0.08 * checker[:, None]
    return np.clip(col, 0.04, 0.92)


def build_pyvista_object(name: str, out_dir: Path) -> dict[str, str]:
    import pyvista as pv
    from pyvista import examples

    loader, up, stripe_dir, hue = PYVISTA_OBJECTS[name]
    mesh = getattr(examples, loader)().triangulate()
    mesh = pv.PolyData(normalise(mesh.points, up), mesh.faces)
    mesh = mesh.subdivide_adaptive(max_edge_len=0.03, max_n_passes=8).clean()
    faces = mesh.faces.reshape(-1, 4)[:, 1:]
    verts = np.asarray(mesh.points, dtype=np.float64)
    path = write_ply(out_dir / f"{name}.ply", verts, faces, colors=pattern_color(verts, stripe_dir, hue))
    return {"mesh": str(path)}


def vase_profile(z: np.ndarray) -> np.ndarray:
    """Radius of the vase at height ``z`` in [-1, 1]: foot, belly, neck, lip."""
    from scipy.interpolate import PchipInterpolator

    zs = [-1.0, -0.85, -0.5, -0.05, 0.35, 0.65, 0.85, 1.0]
    rs = [0.32, 0.45, 0.62, 0.60, 0.38, 0.24, 0.27, 0.34]
    return PchipInterpolator(zs, rs)(z)


def vase_texture(width: int = 512, height: int = 256) -> np.ndarray:
    """The painted texture, ``[height, width, 3]`` uint8 (sRGB); u around, v up."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height        # image row 0 is the top (v = 1)
    U, V = np.meshgrid(u, v)
    glaze = np.stack([0.15 + 0.1 * V, 0.32 + 0.25 * V, 0.55 + 0.2 * V], -1)      # blue glaze
    bands = (np.abs(V - 0.3) < 0.05) | (np.abs(V - 0.72) < 0.03)
    tri = 2 * np.abs(2 * ((U * 12) % 1.0) - 1) - 1                                 # in [-1, 1]
    zig = np.abs(V - (0.5 + 0.06 * tri)) < 0.025
    dots = (((U * 24) % 1 - 0.5) ** 2 + ((V * 12) % 1 - 0.5) ** 2 * 4 < 0.04) & (V > 0.78)
    img = glaze
    img = np.where(bands[..., None], [0.85, 0.7, 0.3], img)
    img = np.where(zig[..., None], [0.9, 0.9, 0.85], img)
    img = np.where(dots[..., None], [0.75, 0.2, 0.15], img)
    return (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8)


def vase_mesh(n_around: int = 160, n_up: int = 120):
    """Surface of revolution with a seam column duplicated (u = 0 and u = 1) and
    two capped ends. Returns ``(vertices, faces, uv)``."""
    z = np.linspace(-1.0, 1.0, n_up)
    r = vase_profile(z)
    theta = np.linspace(0.0, 2 * np.pi, n_around + 1)
    T, Z = np.meshgrid(theta, z)                         # [n_up, n_around + 1]
    R = np.broadcast_to(r[:, None], T.shape)
    verts = np.stack([R * np.cos(T), R * np.sin(T), Z], -1).reshape(-1, 3)
    uv = np.stack([T / (2 * np.pi), (Z + 1) / 2], -1).reshape(-1, 2)
    cols = n_around + 1
    i, j = np.meshgrid(np.arange(n_up - 1), np.arange(n_around), indexing="ij")
    a = (i * cols + j).ravel()
    b, c, d = a + 1, a + cols + 1, a + cols
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    # caps: a fan around a centre vertex at each end
    n0 = len(verts)
    verts = np.concatenate([verts, [[0, 0, -1.0], [0, 0, 1.0]]])
    uv = np.concatenate([uv, [[0.5, 0.0], [0.5, 1.0]]])
    ring_lo = np.arange(n_around)
    ring_hi = (n_up - 1) * cols + np.arange(n_around)
    bottom = np.stack([np.full(n_around, n0), ring_lo + 1, ring_lo], 1)
    top = np.stack([np.full(n_around, n0 + 1), ring_hi, ring_hi + 1], 1)
    faces = np.concatenate([faces, bottom, top])
    verts = verts / np.linalg.norm(verts, axis=1).max() * 0.95
    return verts, faces, uv


def build_textured(name: str, out_dir: Path, verts, faces, uv, texture: np.ndarray) -> dict[str, str]:
    """Write a mesh with UVs and its sRGB texture (``[H, W, 3]`` uint8)."""
    import imageio.v3 as iio

    mesh = write_ply(out_dir / f"{name}.ply", verts, faces, uv=uv)
    tex = atomic_write_bytes(out_dir / f"{name}_texture.png", iio.imwrite("<bytes>", texture, extension=".png"))
    return {"mesh": str(mesh), "texture": str(tex)}


def build_object(name: str, out_dir: Path) -> dict[str, str]:
    """Write the assets of 3D object ``name`` into ``out_dir``; return XML variables."""
    if name == "vase":
        return build_textured(name, out_dir, *vase_mesh(), vase_texture())
    if name == "brick":
        return build_textured(name, out_dir, *brick_mesh())
    return build_pyvista_object(name, out_dir)


OBJECTS_3D = ("vase", "brick", *PYVISTA_OBJECTS)
