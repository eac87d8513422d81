"""Author the 2D scene outlines stored in ``scenes_xml/polygons/*.json``.

Run once (``python scripts/author_polygons.py``); the JSON files are the data the
package reads. Every outline is a closed ring (last point == first point, as in
GeoJSON), counter-clockwise, centred, and fits inside a radius of ~1.5 so that
cameras on a radius-4 circle with a 53 degree field of view see all of it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.interpolate import splev, splprep

OUT = Path(__file__).resolve().parents[1] / "scenes_xml" / "polygons"


def ring(points) -> list[list[float]]:
    pts = [[round(float(x), 5), round(float(y), 5)] for x, y in points]
    return pts + [pts[0]]


def arc(cx, cy, r, a0, a1, n):
    a = np.linspace(np.radians(a0), np.radians(a1), n)
    return np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], 1)


def square():
    return [(-0.8, -0.8), (0.8, -0.8), (0.8, 0.8), (-0.8, 0.8)]


def square_concave():
    # The square with a rectangular notch cut into its right side.
    return [(-0.8, -0.8), (0.8, -0.8), (0.8, -0.3), (0.2, -0.3),
            (0.2, 0.3), (0.8, 0.3), (0.8, 0.8), (-0.8, 0.8)]


def tu():
    # The letters "TU" as one outline: the T's bar runs into the U's left arm.
    pts = [(-0.9, -1.0), (-0.5, -1.0), (-0.5, 0.6), (0.1, 0.6), (0.1, -0.4)]
    pts += [tuple(p) for p in arc(0.7, -0.4, 0.6, 180, 360, 13)[1:-1]]
    pts += [(1.3, -0.4), (1.3, 1.0), (0.9, 1.0), (0.9, -0.4)]
    pts += [tuple(p) for p in arc(0.7, -0.4, 0.2, 360, 180, 7)[1:-1]]
    pts += [(0.5, -0.4), (0.5, 1.0), (-1.3, 1.0), (-1.3, 0.6), (-0.9, 0.6)]
    return pts


BUNNY_KEYS = [  # a sitting bunny facing right, counter-clockwise, in arbitrary units
    (2.0, 0.0), (4.5, 0.0), (7.2, 0.0), (7.5, 0.4), (6.6, 0.9), (6.7, 2.0), (7.3, 3.2),
    (8.2, 4.0), (9.0, 4.4), (9.3, 5.0), (8.9, 5.8), (8.0, 6.3), (7.8, 7.5), (7.9, 8.7),
    (7.5, 9.1), (7.0, 8.6), (6.9, 7.2), (6.7, 6.6), (6.3, 7.4), (5.8, 8.5), (5.3, 8.7),
    (5.2, 8.1), (5.8, 6.7), (5.5, 5.8), (4.0, 5.5), (2.4, 5.0), (1.3, 4.0), (0.6, 4.2),
    (0.2, 3.5), (0.6, 2.9), (0.8, 2.2), (1.0, 1.0), (1.6, 0.3),
]


def bunny(n: int = 96):
    keys = np.array(BUNNY_KEYS + [BUNNY_KEYS[0]], float)
    tck, _ = splprep(keys.T, s=0.0, per=True)
    x, y = splev(np.linspace(0, 1, n, endpoint=False), tck)
    pts = np.stack([x, y], 1)
    pts -= (pts.max(0) + pts.min(0)) / 2
    pts *= 2.8 / np.ptp(pts, axis=0).max()
    return [tuple(p) for p in pts]


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for name, fn in [("square", square), ("square_concave", square_concave),
                     ("bunny", bunny), ("tu", tu)]:
        data = {"name": name, "points": ring(fn())}
        (OUT / f"{name}.json").write_text(json.dumps(data, indent=1) + "\n")
        print(name, len(data["points"]) - 1, "vertices")


if __name__ == "__main__":
    main()
