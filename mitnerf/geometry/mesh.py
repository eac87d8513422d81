"""Isosurface meshes of a learned density, by marching cubes, and Chamfer distances between meshes.

A field's surface is ``sigma(x) == level``. ``extract_mesh`` samples ``density`` (any callable ``points [m, 3]
float32 -> [m]``) on ``resolution^3`` nodes spanning ``[-b, b]^3`` (spacing ``h = 2 b / (resolution - 1)``) and
runs scikit-image's ``measure.marching_cubes``. Vertices are in world units; faces are wound counter-clockwise
seen from the low-density side (normals out: a closed mesh has positive signed volume). ``close=True`` pads the
grid with one layer of empty space, so matter that reaches the cube's faces is capped there.

Level: a slab ``t`` thick at density ``sigma`` stops ``1 - exp(-sigma t)`` of a ray (:func:`level_for_opacity`);
higher levels shrink the mesh towards the dense core, lower ones inflate it; ``'auto'`` is :func:`auto_level`.
When no surface exists at ``level``, the error names the range the densities span.

Chamfer: the symmetric mean of unsquared nearest-neighbour distances (the "L1" Chamfer distance) between ``N``
points sampled uniformly by area on each mesh (``numpy.random.default_rng(seed)``), in world units. Two samplings
of the same surface of area ``S`` lie ``0.5 * sqrt(S / N)`` apart on average: differences well above that are real.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from tqdm.auto import tqdm

from ..errors import MitnerfError
from ..scenes.ply import read_ply, write_ply

LEVEL = 3.0
"""The density taken as the surface of matter by the geometry metrics (IoU, Chamfer) and ``mitnerf video``'s mesh:
half the light is gone after 0.23 units. Grid fields peak near 10-30, so the usual NeRF level 10 cuts holes."""


@dataclass
class Mesh:
    """A triangle mesh in world units."""

    vertices: np.ndarray
    """``[v, 3]`` float64 positions."""
    faces: np.ndarray
    """``[f, 3]`` int64 vertex indices, counter-clockwise seen from outside."""
    level: float | None = None
    """The density level it was extracted at (``None`` for meshes read from files)."""
    info: dict = field(default_factory=dict)
    """How it was made (bound, resolution, grid density range, evaluation time)."""

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, np.float64).reshape(-1, 3)
        self.faces = np.asarray(self.faces, np.int64).reshape(-1, 3)

    @property
    def triangles(self) -> np.ndarray:
        """Corner positions ``[f, 3 corners, 3]``."""
        return self.vertices[self.faces]

    def face_areas(self) -> np.ndarray:
        """``[f]`` triangle areas."""
        t = self.triangles
        return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)

    @property
    def area(self) -> float:
        return float(self.face_areas().sum())

    @property
    def volume(self) -> float:
        """Signed enclosed volume (divergence theorem); positive for outward-wound closed meshes."""
        t = self.triangles
        return float(np.einsum("fi,fi->f", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)

    def save(self, path: str | Path) -> Path:
        """Binary little-endian PLY (float32 positions, int32 indices) via :func:`write_ply`."""
        return write_ply(path, self.vertices.astype(np.float32), self.faces.astype(np.int32))

    def to_pyvista(self):
        import pyvista as pv

        return pv.PolyData(self.vertices, np.c_[np.full(len(self.faces), 3), self.faces].ravel())


def mesh_from_ply(path: str | Path) -> Mesh:
    """Read a mesh written by :func:`write_ply` (ours or a scene's ground truth)."""
    path = Path(path)
    if not path.exists():
        raise MitnerfError(f"mesh file {path} does not exist; pass the path of a PLY written by mitnerf")
    ply = read_ply(path)
    return Mesh(ply["vertices"], ply["faces"])


def as_mesh(obj) -> Mesh:
    """A :class:`Mesh` from a Mesh, a PLY path, a ``(vertices, faces)`` pair or a pyvista PolyData."""
    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, (str, Path)):
        return mesh_from_ply(obj)
    if isinstance(obj, tuple) and len(obj) == 2:
        return Mesh(*obj)
    if hasattr(obj, "triangulate") and hasattr(obj, "points"):      # pyvista.PolyData
        tri = obj.triangulate()
        return Mesh(np.asarray(tri.points), np.asarray(tri.faces).reshape(-1, 4)[:, 1:])
    raise MitnerfError(f"cannot read a mesh from {type(obj).__name__}; pass a Mesh, a PLY path, "
                       "(vertices, faces) or a pyvista PolyData")


def level_for_opacity(opacity: float, thickness: float) -> float:
    """The density at which a layer ``thickness`` thick stops ``opacity`` of the light:
    ``-ln(1 - opacity) / thickness`` (e.g. 0.5 over 0.03 units -> 23.1)."""
    if not (0 < opacity < 1 and thickness > 0):
        raise MitnerfError(f"need 0 < opacity < 1 and thickness > 0, got {opacity}, {thickness}")
    return float(-np.log1p(-opacity) / thickness)


def density_volume(density: Callable[[np.ndarray], np.ndarray], bound: float, resolution: int = 128,
                 center=(0.0, 0.0, 0.0), chunk: int = 1 << 18, progress: bool = True) -> np.ndarray:
    """Densities at the grid nodes, ``[R, R, R]`` float32 indexed ``[ix, iy, iz]``: node ``(i, j, k)``
    sits at ``center + (a[i], a[j], a[k])``, ``a = linspace(-bound, bound, R)``. Evaluated in x-slabs
    of about ``chunk`` points each."""
    if resolution < 2:
        raise MitnerfError(f"grid resolution must be at least 2, got {resolution}; use 128")
    if not bound > 0:
        raise MitnerfError(f"bound must be positive, got {bound}; pass the half-width of the object's cube")
    R = int(resolution)
    a = np.linspace(-bound, bound, R)
    Y, Z = np.meshgrid(a, a, indexing="ij")                          # [R, R] each
    yz = np.stack([Y.ravel(), Z.ravel()], 1) + np.asarray(center)[1:]  # [R*R, 2]
    slabs = max(1, chunk // (R * R))
    grid = np.empty((R, R, R), np.float32)
    with tqdm(total=R, desc="density grid", unit="slab", disable=not progress, leave=False) as bar:
        for s in range(0, R, slabs):
            xs = a[s:s + slabs] + center[0]
            pts = np.concatenate([np.c_[np.full(len(yz), x), yz] for x in xs]).astype(np.float32)  # [n*R*R, 3]
            sigma = np.asarray(density(pts), np.float32).reshape(-1)
            if sigma.size != len(pts):
                raise MitnerfError(f"density() returned {sigma.size} values for {len(pts)} points; "
                                   "it must map points [m, 3] to densities [m]")
            grid[s:s + len(xs)] = sigma.reshape(len(xs), R, R)
            bar.update(len(xs))
    bad = int(np.count_nonzero(~np.isfinite(grid)))
    if bad:
        raise MitnerfError(f"the density is NaN or infinite at {bad} of {grid.size} grid points; the field "
                           "diverged: retrain with a lower --lr or --density-activation softplus")
    return grid


def auto_level(grid: np.ndarray, floor: float = 1e-3) -> float:
    """Otsu's threshold of ``log10(sigma)`` over the grid nodes with ``sigma > floor``, as a density.
    Empty space (often most of the grid, exactly 0 for ReLU fields) is left out: Otsu would split
    off its spike instead of matter from haze. A field of empty space and one density ``s`` gets ``s / 2``."""
    from skimage.filters import threshold_otsu

    grid = np.asarray(grid, np.float64)
    matter = grid[grid > floor]
    if matter.size == 0 or matter.size == grid.size and np.ptp(matter) <= 1e-6 * matter.max():
        raise MitnerfError(f"cannot choose a level automatically: {_level_hint(grid)}; there is no matter "
                           f"(densities above {floor:g}) next to empty space: train longer, check the bound, "
                           "or pass a level")
    logs = np.log10(matter)
    if np.ptp(logs) < 1e-6:
        return float(matter.max() / 2)
    return float(10.0 ** threshold_otsu(logs))


def _level_hint(grid: np.ndarray) -> str:
    p = np.percentile(grid, [1, 50, 99])
    return (f"the field's densities on the {grid.shape[0]}^3 grid span [{grid.min():.3g}, {grid.max():.3g}] "
            f"(1st/50th/99th percentiles {p[0]:.3g}/{p[1]:.3g}/{p[2]:.3g})")


def mesh_from_grid(grid: np.ndarray, bound: float, level: float | str = 10.0, center=(0.0, 0.0, 0.0),
                   close: bool = True) -> Mesh:
    """Marching cubes on a :func:`density_volume` result; vertices in world units."""
    from skimage import measure

    grid = np.asarray(grid, np.float32)
    R = grid.shape[0]
    if level == "auto":
        level = auto_level(grid)
    try:
        level = float(level)
    except (TypeError, ValueError):
        raise MitnerfError(f"level must be a number or 'auto', got {level!r}") from None
    lo, hi = float(grid.min()), float(grid.max())
    if not lo < level < hi:
        side = "below" if level >= hi else "above"
        try:
            fix = f"; choose a level inside that range, e.g. {auto_level(grid):.3g} (what level 'auto' picks)"
        except MitnerfError:
            fix = "; the field has no structure to mesh: train longer or check the bound"
        raise MitnerfError(f"no surface at density level {level:g}: every grid density is {side} it; "
                           f"{_level_hint(grid)}{fix}")
    h = 2.0 * bound / (R - 1)
    origin = -bound - h if close else -bound
    if close:                                   # a layer of empty space caps matter at the cube's faces
        grid = np.pad(grid, 1, constant_values=min(lo, level) - 1.0)
    verts, faces, _, _ = measure.marching_cubes(grid, level=level, spacing=(h, h, h), allow_degenerate=False)
    # skimage winds faces clockwise seen from the side of lower values; flip to counter-clockwise
    return Mesh(verts + origin + np.asarray(center, np.float64), faces[:, ::-1], level,
                {"bound": bound, "resolution": R, "spacing": h, "density_min": lo, "density_max": hi})


def extract_mesh(density: Callable[[np.ndarray], np.ndarray], bound: float, resolution: int = 128,
                 level: float | str = 10.0, center=(0.0, 0.0, 0.0), chunk: int = 1 << 18,
                 progress: bool = True, close: bool = True) -> Mesh:
    """The ``density == level`` surface inside ``center + [-bound, bound]^3``; see the module docstring."""
    t0 = time.perf_counter()
    grid = density_volume(density, bound, resolution, center, chunk, progress)
    t_grid = time.perf_counter() - t0
    mesh = mesh_from_grid(grid, bound, level, center, close)
    mesh.info.update(grid_seconds=t_grid, seconds=time.perf_counter() - t0)
    return mesh


@dataclass
class ChamferResult:
    """Chamfer distance and its two one-sided parts, in world units."""

    chamfer: float
    """``(a_to_b + b_to_a) / 2``."""
    a_to_b: float
    """Mean distance from samples of A to the nearest sample of B (accuracy of A)."""
    b_to_a: float
    """Mean distance from samples of B to the nearest sample of A (completeness of A)."""
    n_points: int
    """Samples drawn on each surface."""
    floor: float
    """The sampling floor ``0.5 * sqrt(area / n_points)`` of the larger surface."""

    def __str__(self) -> str:
        return (f"chamfer {self.chamfer:.4g} (learned->truth {self.a_to_b:.4g}, truth->learned {self.b_to_a:.4g}; "
                f"{self.n_points} samples each, sampling floor ~{self.floor:.2g})")


def sample_surface(mesh, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points ``[n, 3]`` uniform by area on ``mesh`` (anything :func:`as_mesh` reads)."""
    mesh = as_mesh(mesh)
    areas = mesh.face_areas()                                     # [f]
    total = areas.sum()
    if len(mesh.faces) == 0 or not total > 0:
        raise MitnerfError("cannot sample an empty mesh (no faces or zero area); extract it at another level")
    face = rng.choice(len(areas), size=n, p=areas / total)        # [n]
    u, r2 = np.sqrt(rng.random(n)), rng.random(n)
    w = np.stack([1 - u, u * (1 - r2), u * r2], 1)                # [n, 3] barycentric
    return np.einsum("nk,nkd->nd", w, mesh.triangles[face])


def chamfer_distance(a, b, n_points: int = 100_000, seed: int = 0) -> ChamferResult:
    """Chamfer distance between meshes ``a`` and ``b`` (Mesh, PLY path, (v, f) or pyvista)."""
    from scipy.spatial import cKDTree

    if n_points < 1:
        raise MitnerfError(f"n_points must be positive, got {n_points}")
    a, b = as_mesh(a), as_mesh(b)
    rng = np.random.default_rng(seed)
    P, Q = sample_surface(a, n_points, rng), sample_surface(b, n_points, rng)    # [N, 3] each
    a_to_b, b_to_a = float(cKDTree(Q).query(P)[0].mean()), float(cKDTree(P).query(Q)[0].mean())
    floor = 0.5 * np.sqrt(max(a.area, b.area) / n_points)
    return ChamferResult(0.5 * (a_to_b + b_to_a), a_to_b, b_to_a, n_points, float(floor))


CHAMFER_RESOLUTION, CHAMFER_POINTS = 128, 100_000
"""mitnerf's Chamfer distance of a field (the one definition, in ``fit``'s metrics and ``video``'s alike): its
``density == LEVEL`` surface by marching cubes on a ``CHAMFER_RESOLUTION^3`` grid over its bound, against the
true mesh, ``CHAMFER_POINTS`` surface samples each way, seed 0."""


def field_chamfer(density: Callable[[np.ndarray], np.ndarray], bound: float, truth, mesh: Mesh | None = None,
                  progress: bool = False) -> ChamferResult:
    """The Chamfer distance of a field to ``truth`` by mitnerf's definition (:data:`CHAMFER_RESOLUTION`); ``mesh``:
    that surface when the caller has it already."""
    mesh = mesh or extract_mesh(density, bound, CHAMFER_RESOLUTION, LEVEL, progress=progress)
    return chamfer_distance(mesh, truth, n_points=CHAMFER_POINTS, seed=0)
