"""Closed 2D outlines: validation, colour along the outline, and the extruded prism.

A :class:`Polygon` is a simple (non-self-intersecting) closed ring. Input follows GeoJSON: the last point repeats
the first (an open polyline is refused). The ring is stored without the repeated point and counter-clockwise, so
every wall of the prism faces outward (Mitsuba's diffuse surfaces are one-sided).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MitnerfError, Note

MAX_POINTS = 10_000
"""Most outline points mitnerf takes (the self-intersection test is quadratic in them)."""


def _segments_intersect(p, p2, q, q2) -> np.ndarray:
    """Proper or touching intersection of segment sets [p, p2] and [q, q2] (broadcast)."""
    def orient(a, b, c):
        return np.sign((b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
                       - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0]))

    def on_segment(a, b, c):  # c collinear with a-b: is it inside the box?
        return ((np.minimum(a, b) <= c) & (c <= np.maximum(a, b))).all(-1)

    o1, o2 = orient(p, p2, q), orient(p, p2, q2)
    o3, o4 = orient(q, q2, p), orient(q, q2, p2)
    proper = (o1 * o2 < 0) & (o3 * o4 < 0)
    touch = (((o1 == 0) & on_segment(p, p2, q)) | ((o2 == 0) & on_segment(p, p2, q2))
             | ((o3 == 0) & on_segment(q, q2, p)) | ((o4 == 0) & on_segment(q, q2, p2)))
    return proper | touch


def outline_color(s: np.ndarray) -> np.ndarray:
    """Diffuse reflectance ``[len(s), 3]`` at ``s`` = arc length / perimeter in [0, 1): a smooth
    hue cycle kept inside [0.12, 0.88] so that no wall is black or saturated."""
    phase = np.array([0.0, 1.0 / 3.0, 2.0 / 3.0])
    return 0.5 + 0.38 * np.cos(2.0 * np.pi * (s[:, None] + phase))


def outline_stripes(perimeter: float, texels_per_unit: int = 200, seed: int = 0) -> np.ndarray:
    """A 1D texture along the outline for the ``textured`` material: the colour cycle of :func:`outline_color`
    crossed by a barcode of dark bars and gaps 0.025, 0.05 or 0.1 world units wide (about 0.6 to 2.5
    pixels of a 100-pixel view from radius 4). Linear reflectance, ``[1, W, 3]`` float32; texel ``k``
    covers arc-length fraction ``[k, k + 1) / W``."""
    n = int(np.ceil(perimeter * texels_per_unit))
    s = (np.arange(n) + 0.5) / n
    widths = np.random.default_rng(seed).choice([0.025, 0.05, 0.1], size=int(perimeter / 0.025) + 1)
    bar = np.searchsorted(np.cumsum(widths) / perimeter, s, side="right") % 2 == 1
    col = outline_color(s)
    col[bar] *= 0.12
    return col[None].astype(np.float32)


@dataclass(frozen=True)
class Polygon:
    """A simple closed outline, counter-clockwise, without the repeated end point."""

    points: np.ndarray  # [n, 2]
    name: str = "custom"

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_points(cls, points, name: str = "custom") -> "Polygon":
        """Validate a closed ring (last point == first point) and normalise its winding."""
        if isinstance(points, (list, tuple)):          # from JSON: real numbers only, not "0.5" or true
            for i, p in enumerate(points):
                if not (isinstance(p, (list, tuple)) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                             for v in p)):
                    raise MitnerfError(f"polygon {name!r}: point {i} is {json.dumps(p, default=str)[:40]}, not a "
                                       "pair of numbers; write the points as [[x0, y0], [x1, y1], ..., [x0, y0]]")
        try:
            pts = np.asarray(points, dtype=np.float64)
        except (TypeError, ValueError):
            raise MitnerfError(f"polygon {name!r}: points must be a list of [x, y] pairs") from None
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise MitnerfError(f"polygon {name!r}: expected a list of [x, y] points, got an array of shape "
                               f"{pts.shape}; write it as [[x0, y0], [x1, y1], ..., [x0, y0]]")
        if not np.all(np.isfinite(pts)):
            raise MitnerfError(f"polygon {name!r}: a point is NaN or infinite; give finite coordinates")
        was_open = len(pts) >= 3 and not np.allclose(pts[0], pts[-1], atol=1e-9)
        if was_open:
            pts = np.vstack([pts, pts[:1]])
        if len(pts) < 2:
            raise MitnerfError(f"polygon {name!r} has {len(pts)} points; a closed outline needs at least 3")
        pts = pts[:-1]
        if len(pts) > MAX_POINTS:
            raise MitnerfError(f"polygon {name!r} has {len(pts)} points; mitnerf takes at most {MAX_POINTS}: "
                               "simplify the outline")
        if len(np.unique(np.round(pts, 12), axis=0)) != len(pts):
            raise MitnerfError(f"polygon {name!r} repeats a vertex; remove the duplicate points")
        if len(pts) < 3:
            raise MitnerfError(f"polygon {name!r} has {len(pts)} distinct points; a closed outline needs at least 3")
        poly = cls(pts, name)
        bad = poly.self_intersections()
        if bad:
            i, j = bad[0]
            raise MitnerfError(f"polygon {name!r} is self-intersecting: edge {i} crosses edge {j}; "
                               "reorder or move the points so that the outline does not cross itself")
        area = poly.signed_area()
        if abs(area) < 1e-12:
            raise MitnerfError(f"polygon {name!r} has zero area; its points are collinear")
        if area < 0:
            poly = cls(pts[::-1].copy(), name)
        if was_open:
            warnings.warn(f"polygon {name!r} was open (its last point differs from its first): closed it with an "
                          "edge from its last point to its first", Note, stacklevel=2)
        return poly

    @classmethod
    def from_json(cls, path: str | Path) -> "Polygon":
        """Read ``{"name": ..., "points": [[x, y], ...]}`` or a bare list of points."""
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except OSError as exc:
            raise MitnerfError(f"cannot read polygon file {path}: {exc.strerror}; check the path") from None
        except UnicodeDecodeError:
            raise MitnerfError(f"polygon file {path} is not UTF-8 text; save it as UTF-8 JSON") from None
        except json.JSONDecodeError as exc:
            raise MitnerfError(f"polygon file {path} is not valid JSON ({exc.msg} at line {exc.lineno}); "
                               "fix the file") from None
        except RecursionError:
            raise MitnerfError(f"polygon file {path} nests too deeply to be a list of points; fix the file") from None
        if isinstance(data, dict):
            name = data.get("name", path.stem)
            if not isinstance(name, str):
                raise MitnerfError(f"polygon file {path}: 'name' must be a string, got "
                                   f"{json.dumps(name, default=str)[:40]}; fix or delete it")
            return cls.from_points(data.get("points", []), name)
        return cls.from_points(data, path.stem)

    # ----------------------------------------------------------------- geometry
    @property
    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Edge start and end points, each ``[n, 2]``."""
        return self.points, np.roll(self.points, -1, axis=0)

    def signed_area(self) -> float:
        x, y = self.points[:, 0], self.points[:, 1]
        return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))

    def perimeter(self) -> float:
        a, b = self.edges
        return float(np.linalg.norm(b - a, axis=1).sum())

    def radius(self) -> float:
        """Largest distance of a vertex from the origin."""
        return float(np.linalg.norm(self.points, axis=1).max())

    def self_intersections(self) -> list[tuple[int, int]]:
        """Pairs of non-adjacent edges that touch or cross."""
        a, b = self.edges
        n = len(a)
        out = []
        rows = max(1, (1 << 21) // max(n, 1))     # pairs tested in blocks of about 2M: bounded memory
        for i0 in range(0, n, rows):
            I, J = np.arange(i0, min(n, i0 + rows))[:, None], np.arange(n)[None, :]
            i, j = np.nonzero((J >= I + 2) & ~((I == 0) & (J == n - 1)))  # the first and last edges share a vertex
            i += i0
            hit = _segments_intersect(a[i], b[i], a[j], b[j])
            out += zip(i[hit].tolist(), j[hit].tolist())
        return out

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Even-odd inside test for points ``[m, 2]``."""
        from matplotlib.path import Path as MplPath

        return MplPath(self.points).contains_points(np.asarray(xy))

    def intersect(self, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """Distance ``[m]`` along rays ``origins, dirs [m, 2]`` to the first wall, ``inf`` on a miss:
        analytic, the reference the rendered depth is tested against."""
        return self.wall_hits(origins, dirs)[0]

    def wall_hits(self, origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where rays ``origins, dirs [m, 2]`` first meet a wall: the distance ``[m]`` (``inf`` on a miss), the arc
        length there as a fraction of the perimeter from the first point ``[m]`` and the wall's outward unit
        normal ``[m, 2]`` (both 0 on a miss)."""
        a, b = self.edges
        e = b - a                                        # [n, 2]
        o, d = origins[:, None, :], dirs[:, None, :]     # [m, 1, 2]
        denom = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
        w = a[None] - o
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / denom
            u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / denom
        ok = (np.abs(denom) > 1e-12) & (t > 1e-9) & (u >= 0) & (u <= 1)
        t = np.where(ok, t, np.inf)
        k = t.argmin(axis=1)                             # [m] the wall met first
        rows = np.arange(len(k))
        dist, hit = t[rows, k], ok[rows, k]
        length = np.linalg.norm(e, axis=1)
        start = np.concatenate([[0.0], np.cumsum(length)[:-1]])
        arc = np.where(hit, (start[k] + u[rows, k] * length[k]) / length.sum(), 0.0)
        normal = np.stack([e[:, 1], -e[:, 0]], 1) / length[:, None]        # outward: the ring is counter-clockwise
        return dist, arc, np.where(hit[:, None], normal[k], 0.0)

    # ----------------------------------------------------------------- the prism
    def resampled(self, max_len: float) -> tuple[np.ndarray, np.ndarray]:
        """Outline points ``[m, 2]`` with no wall segment longer than ``max_len`` (for smooth
        colour) and their arc-length fractions ``s`` ``[m]``."""
        a, b = self.edges
        pts, s, acc, total = [], [], 0.0, self.perimeter()
        for p, q in zip(a, b):
            seg = float(np.linalg.norm(q - p))
            k = max(1, int(np.ceil(seg / max_len)))
            for t in np.arange(k) / k:
                pts.append(p + t * (q - p))
                s.append((acc + t * seg) / total)
            acc += seg
        return np.array(pts), np.array(s)

    def prism(self, half_height: float = 1.0, max_len: float = 0.05):
        """Triangle mesh ``(vertices [v, 3], faces [f, 3], colors [v, 3])`` of the outline extruded
        to ``z in [-h, h]``, walls outward. Every wall segment owns four vertices (flat walls),
        coloured by :func:`outline_color`; the caps are triangulated with VTK."""
        import pyvista as pv

        pts, s = self.resampled(max_len)
        nxt, col = np.roll(pts, -1, axis=0), outline_color(s)
        col_nxt = np.roll(col, -1, axis=0)
        h, m, k = half_height, len(pts), len(self.points)
        walls = np.empty((m, 4, 3))
        walls[:, :, :2] = np.stack([pts, nxt, nxt, pts], axis=1)
        walls[:, :, 2] = [-h, -h, h, h]
        base = 4 * np.arange(m)[:, None]
        cap = pv.PolyData(np.c_[self.points, np.zeros(k)], faces=np.r_[k, np.arange(k)]).triangulate()
        tri = cap.faces.reshape(-1, 4)[:, 1:]
        top, bottom = np.c_[self.points, np.full(k, h)], np.c_[self.points, np.full(k, -h)]
        verts = np.concatenate([walls.reshape(-1, 3), top, bottom])
        cols = np.concatenate([np.stack([col, col_nxt, col_nxt, col], axis=1).reshape(-1, 3),
                               np.full((2 * k, 3), 0.5)])    # grey caps: never seen from the z = 0 plane
        faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3], 4 * m + tri, 4 * m + k + tri[:, ::-1]])
        return verts.astype(np.float32), faces.astype(np.int32), cols.astype(np.float32)

    def prism_uv(self, half_height: float = 1.0, max_len: float = 0.05):
        """``(vertices, faces, uv [v, 2])``: :meth:`prism` with ``u`` the arc-length fraction along the wall (1 at the
        closing vertex, so a texture wraps once) and ``v`` up instead of colours; caps sit at ``u = 0``."""
        v, f, _ = self.prism(half_height, max_len)
        _, s = self.resampled(max_len)
        s_next = np.r_[s[1:], 1.0]
        uv = np.zeros((len(v), 2), np.float32)
        uv[:4 * len(s), 0] = np.stack([s, s_next, s_next, s], 1).ravel()
        uv[:, 1] = (v[:, 2] + half_height) / (2 * half_height)
        return v, f, uv
