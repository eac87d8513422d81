"""3D objects for the window-shopping experiments: product-like meshes, textured.

* ``ant``, ``airplane``, ``nut``: the pyvista wheel's meshes, turned z-up into the unit sphere, subdivided, and
  painted with a procedural 3D pattern in vertex colours (no UVs);
* ``vase``: a procedural surface of revolution with UVs and a painted image texture;
* ``brick``: a Lego-like toy bulldozer (tiny-NeRF's Lego stand-in) of boxes and short cylinders, each face with
  its own cell in one texture atlas of high-contrast prints at ~160 texels per model unit (the toy is ~5.5
  units long before it is scaled into the unit sphere), so a field needs high encoding frequencies to fit it.

Each builder writes its assets (PLY, PNG) and returns them as XML ``$variables``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._io import atomic_write_bytes
from .ply import grid_faces, normalise, write_ply

# name -> (pyvista loader, up axis of the raw mesh, stripe direction, hue offset)
PYVISTA_OBJECTS = {
    "ant": ("load_ant", 1, (0.3, 0.9, 0.3), 0.0),
    "airplane": ("load_airplane", 2, (1.0, 0.2, 0.4), 0.35),
    "nut": ("load_nut", 1, (0.2, 0.3, 1.0), 0.7),
}


def pattern_color(p: np.ndarray, stripe_dir, hue: float) -> np.ndarray:
    """A procedural 3D texture: a hue ramp up the object, crossed by soft stripes and
    a finer checker, so that fields need real spatial frequency to fit it. ``[v, 3]``."""
    a = np.asarray(stripe_dir, float) / np.linalg.norm(stripe_dir)
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
    return {"mesh": str(write_ply(out_dir / f"{name}.ply", verts, faces, colors=pattern_color(verts, stripe_dir, hue)))}


def vase_texture(width: int = 512, height: int = 256) -> np.ndarray:
    """The painted texture, ``[height, width, 3]`` uint8 (sRGB); u around, v up."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height        # image row 0 is the top (v = 1)
    U, V = np.meshgrid(u, v)
    img = np.stack([0.15 + 0.1 * V, 0.32 + 0.25 * V, 0.55 + 0.2 * V], -1)        # blue glaze
    bands = (np.abs(V - 0.3) < 0.05) | (np.abs(V - 0.72) < 0.03)
    tri = 2 * np.abs(2 * ((U * 12) % 1.0) - 1) - 1                                 # in [-1, 1]
    zig = np.abs(V - (0.5 + 0.06 * tri)) < 0.025
    dots = (((U * 24) % 1 - 0.5) ** 2 + ((V * 12) % 1 - 0.5) ** 2 * 4 < 0.04) & (V > 0.78)
    for mask, colour in ((bands, [0.85, 0.7, 0.3]), (zig, [0.9, 0.9, 0.85]), (dots, [0.75, 0.2, 0.15])):
        img = np.where(mask[..., None], colour, img)
    return (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8)


def table_texture(size: int = 512, seed: int = 0) -> np.ndarray:
    """A print that repeats nowhere, ``[size, size, 3]`` uint8 (sRGB): white noise blurred at 1, 2, 4 and 8 texels
    and summed, each channel stretched to [0, 1]. Structure from motion needs it: SIFT finds blobs at every scale,
    none alike (the objects are symmetric or print repeating patterns, which COLMAP mistakes for one another)."""
    from scipy.ndimage import gaussian_filter

    noise = np.random.default_rng(seed).standard_normal((size, size, 3))
    img = sum(s * gaussian_filter(noise, (s, s, 0), mode="wrap") for s in (1, 2, 4, 8))
    img = (img - img.min((0, 1))) / np.ptp(img, (0, 1))
    return (img * 255 + 0.5).astype(np.uint8)


def vase_mesh(n_around: int = 160, n_up: int = 120):
    """``(vertices, faces, uv)`` of a surface of revolution, seam column duplicated (u = 0 and 1), ends capped."""
    from scipy.interpolate import PchipInterpolator

    z = np.linspace(-1.0, 1.0, n_up)
    r = PchipInterpolator([-1.0, -0.85, -0.5, -0.05, 0.35, 0.65, 0.85, 1.0],       # radius: foot, belly, neck, lip
                          [0.32, 0.45, 0.62, 0.60, 0.38, 0.24, 0.27, 0.34])(z)
    theta = np.linspace(0.0, 2 * np.pi, n_around + 1)
    T, Z = np.meshgrid(theta, z)                         # [n_up, n_around + 1]
    R = np.broadcast_to(r[:, None], T.shape)
    verts = np.stack([R * np.cos(T), R * np.sin(T), Z], -1).reshape(-1, 3)
    uv = np.stack([T / (2 * np.pi), (Z + 1) / 2], -1).reshape(-1, 2)
    faces = grid_faces(n_up - 1, n_around)
    n0 = len(verts)                                      # caps: a fan around a centre vertex at each end
    verts = np.concatenate([verts, [[0, 0, -1.0], [0, 0, 1.0]]])
    uv = np.concatenate([uv, [[0.5, 0.0], [0.5, 1.0]]])
    ring_lo = np.arange(n_around)
    ring_hi = (n_up - 1) * (n_around + 1) + np.arange(n_around)
    bottom = np.stack([np.full(n_around, n0), ring_lo + 1, ring_lo], 1)
    top = np.stack([np.full(n_around, n0 + 1), ring_hi, ring_hi + 1], 1)
    return verts / np.linalg.norm(verts, axis=1).max() * 0.95, np.concatenate([faces, bottom, top]), uv


# ----------------------------------------------------------------------------- brick: parts
YELLOW, BLACK, GREY = (0.98, 0.76, 0.04), (0.05, 0.05, 0.06), (0.62, 0.64, 0.66)
DARK, RED, BLUE, WHITE = (0.24, 0.25, 0.27), (0.85, 0.08, 0.06), (0.08, 0.25, 0.72), (0.96, 0.96, 0.92)
GLYPHS = {  # 3 x 5 letters, rows top to bottom
    "D": ("110", "101", "101", "101", "110"), "O": ("111", "101", "101", "101", "111"),
    "Z": ("111", "001", "010", "100", "111"), "E": ("111", "100", "110", "100", "111"),
    "R": ("110", "101", "110", "101", "101"),
}
TEXELS_PER_UNIT = 160
ATLAS_WIDTH = 2048
PAD = 3                 # texels of gutter around each cell (bilinear filtering never bleeds)


def box(lo, hi, style: str) -> list[tuple]:
    """Six flat patches ``(fn, ns, nt, width, height, style, role)`` of an axis-aligned box,
    each parametrised so that d/ds x d/dt points outward (vertical faces: t is up)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c, half = (lo + hi) / 2, (hi - lo) / 2
    patches = []
    for k in range(3):
        for sign in (1.0, -1.0):
            n = np.eye(3)[k] * sign
            s, t = (np.eye(3)[0], np.cross(n, np.eye(3)[0])) if k == 2 else (np.cross(np.eye(3)[2], n), np.eye(3)[2])
            hs, ht = abs(half @ s), abs(half @ t)
            centre = c + n * half[k]

            def fn(S, T, centre=centre, s=s, t=t, hs=hs, ht=ht):
                return centre + ((2 * S - 1) * hs)[..., None] * s + ((2 * T - 1) * ht)[..., None] * t
            role = "side" if k < 2 else ("top" if sign > 0 else "bottom")
            patches.append((fn, 1, 1, 2 * hs, 2 * ht, style, role))
    return patches


def cylinder(centre, axis: int, radius: float, length: float, style: str, segments: int = 32) -> list[tuple]:
    """Side and both caps of a cylinder along world axis ``axis`` (caps in polar texture
    coordinates: s around, t out from the centre)."""
    a = np.eye(3)[axis]
    e1 = np.eye(3)[(axis + 1) % 3]
    e2 = np.cross(a, e1)
    c = np.asarray(centre, float)

    def ring(theta, r):
        return r[..., None] * (np.cos(theta)[..., None] * e1 + np.sin(theta)[..., None] * e2)

    def side(S, T):
        return c + ring(2 * np.pi * S, np.full_like(S, radius)) + ((T - 0.5) * length)[..., None] * a

    def cap(sign):        # the top cap (sign 1) turns the other way round, so that both face outward
        return lambda S, T: c + sign * 0.5 * length * a + ring(-sign * 2 * np.pi * S, T * radius)
    arc = 2 * np.pi * radius
    return [(side, segments, 1, arc, length, style, "side"),
            (cap(1.0), segments, 1, arc, radius, style, "cap"),
            (cap(-1.0), segments, 1, arc, radius, style, "cap")]


def bulldozer() -> list[tuple]:
    """Every patch of the toy, in model units (x forward, z up)."""
    parts = box((-2.4, -1.3, 0.75), (2.4, 1.3, 1.05), "plate")
    parts += box((-2.2, -1.1, 1.05), (0.6, 1.1, 2.0), "body")
    parts += box((0.6, -0.9, 1.05), (1.9, 0.9, 2.6), "cab")
    for x in (-1.55, 1.55):
        parts += cylinder((x, 0, 0.6), 1, 0.07, 3.5, "rod")                  # axles
        for y in (-1.55, 1.55):
            parts += cylinder((x, y, 0.6), 1, 0.6, 0.35, "wheel")
    for xs, ys, z in (((0.95, 1.55), (-0.45, 0.45), 2.675), ((-0.95, -0.3), (-0.55, 0.55), 2.075)):
        for x, y in ((x, y) for x in xs for y in ys):                        # studs on the cab roof and the body
            parts += cylinder((x, y, z), 2, 0.18, 0.15, "stud_yellow", 24)
    for y in (-0.9, -0.3, 0.3, 0.9):                                          # studs on the front deck
        parts += cylinder((2.15, y, 1.12), 2, 0.17, 0.14, "stud", 24)
    edges = np.linspace(-1.6, 1.6, 6)
    for y0, y1 in zip(edges[:-1], edges[1:]):                                # the blade's slats
        parts += box((2.75, y0 + 0.04, 0.2), (2.85, y1 - 0.04, 1.35), "slat")
    parts += box((2.62, -1.6, 0.95), (2.75, 1.6, 1.07), "bar")
    for y in (-1.0, 1.0):                                                    # push arms
        parts += cylinder((2.26, y, 1.2), 0, 0.06, 0.72, "rod", 16)
    for y in (-0.6, 0.0, 0.6):                                               # the ripper's teeth
        parts += box((-2.62, y - 0.07, 0.3), (-2.5, y + 0.07, 1.2), "slat")
    parts += cylinder((-1.5, 0.6, 2.45), 2, 0.1, 0.9, "rod", 16)             # exhaust
    parts += cylinder((1.7, -0.7, 2.95), 2, 0.03, 0.7, "rod", 12)            # antenna
    return parts


# ----------------------------------------------------------------------------- brick: prints
def _text(x, y, x0, y0, cell, text):
    """Mask of ``text`` printed with 3 x 5 glyphs of ``cell`` units, top-left at (x0, y0)."""
    bits = np.array([[[c == "1" for c in row] + [False] for row in GLYPHS[ch]] for ch in text])
    ix = np.floor((x - x0) / cell).astype(int)
    iy = np.floor((y0 - y) / cell).astype(int)
    inside = (ix >= 0) & (ix < 4 * len(text)) & (iy >= 0) & (iy < 5)
    ch, col = np.clip(ix // 4, 0, len(text) - 1), np.clip(ix % 4, 0, 3)
    return inside & bits[ch, np.clip(iy, 0, 4), col]


def paint(style: str, role: str, x: np.ndarray, y: np.ndarray, w: float, h: float) -> np.ndarray:
    """sRGB colour of a face at local coordinates ``x`` (along s) and ``y`` (along t), in
    model units; caps get arc length at the rim and the radius. ``[..., 3]``."""
    def pick(*layers):
        out = np.broadcast_to(np.asarray(layers[0], float), x.shape + (3,)).copy()
        for mask, col in layers[1:]:
            out[mask] = col
        return out
    hazard = ((x + y) / 0.3) % 1.0 < 0.5
    checker = (np.floor(x / 0.15) + np.floor(y / 0.15)) % 2 == 0
    if style == "plate":
        return pick(GREY, (checker, DARK)) if role == "top" else pick(YELLOW, (hazard, BLACK))
    if style == "body":
        if role == "side":
            label = (np.abs(x - w / 2) < 1.05) & (y > 0.28) & (y < 0.92)
            letters = _text(x, y, w / 2 - 0.95, 0.85, 0.1, "DOZER")
            grille = (y > 0.3) & (y < 0.9) & ((x / 0.2) % 1 < 0.5)
            return pick(YELLOW, (grille, BLACK), ((y < 0.22) & hazard, BLACK), (label, RED),
                        (label & letters, WHITE), ((y > h - 0.1) & checker, BLACK))
        if role == "top":
            vents = (np.abs(x - 0.9) < 0.6) & (np.abs(y - h / 2) < 0.85) & ((y / 0.2) % 1 < 0.5)
            return pick(YELLOW, (vents, BLACK), ((x < 0.08) | (y < 0.08) | (h - y < 0.08), BLACK))
        return pick(DARK)
    if style == "cab":
        if role == "side":
            window = (np.abs(x - w / 2) < w / 2 - 0.15) & (y > 0.75) & (y < h - 0.12)
            glint = window & (((x - y) / 0.3) % 1.0 < 0.3)
            band = (y > 0.3) & (y < 0.6) & checker
            return pick(YELLOW, (window, BLUE), (glint, WHITE), (band, BLACK), ((y < 0.2) & hazard, BLACK))
        return pick(DARK, (checker, GREY)) if role == "top" else pick(DARK)
    if style == "wheel":
        if role == "side":
            return pick(BLACK, ((x / 0.2) % 1 < 0.45, GREY))
        s, t = x / w, y / h                                   # angle fraction, radius fraction
        return pick(GREY, (t > 0.72, BLACK), ((t > 0.85) & ((s * 16) % 1 < 0.4), WHITE),
                    ((t > 0.2) & (t < 0.72) & ((s * 6) % 1 < 0.25), RED), (t < 0.2, WHITE))
    if style in ("stud", "stud_yellow"):
        base = YELLOW if style == "stud_yellow" else GREY
        rings = (y / h > 0.45) & (y / h < 0.7) if role == "cap" else (x / 0.15) % 1 < 0.3
        return pick(base, (rings, BLACK))
    if style == "rod":
        return pick(DARK, ((y / 0.1) % 1 < 0.4, WHITE)) if role == "side" else pick(DARK)
    if style == "slat":
        return pick(WHITE, ((y / 0.25) % 1 < 0.5, RED))
    return pick(BLACK, ((x / 0.2) % 1 < 0.5, YELLOW))          # the blade's bar


# ----------------------------------------------------------------------------- brick: mesh + atlas
def brick_mesh() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(vertices [v, 3], faces [f, 3], uv [v, 2], texture [H, W, 3] uint8 sRGB)``, the toy
    centred, z up, scaled to radius 0.95."""
    patches = bulldozer()
    cells = [(int(np.ceil(w * TEXELS_PER_UNIT)) + 2 * PAD, int(np.ceil(h * TEXELS_PER_UNIT)) + 2 * PAD)
             for _, _, _, w, h, _, _ in patches]
    origin, x0, y0, row_h = [], 0, 0, 0                     # shelf packing, tallest first
    for k in sorted(range(len(cells)), key=lambda k: -cells[k][1]):
        cw, ch = cells[k]
        if x0 + cw > ATLAS_WIDTH:
            x0, y0, row_h = 0, y0 + row_h, 0
        origin.append((k, x0, y0))
        x0, row_h = x0 + cw, max(row_h, ch)
    height = y0 + row_h
    tex = np.zeros((height, ATLAS_WIDTH, 3))
    verts, faces, uvs, n = [], [], [], 0
    for k, cx, cy in sorted(origin):
        fn, ns, nt, w, h, style, role = patches[k]
        cw, ch = cells[k]
        iw, ih = cw - 2 * PAD, ch - 2 * PAD
        px, py = np.meshgrid(np.arange(cw) + 0.5 - PAD, np.arange(ch) + 0.5 - PAD)
        S, T = px / iw, 1.0 - py / ih                       # image rows go down, t goes up
        tex[cy:cy + ch, cx:cx + cw] = paint(style, role, S * w, T * h, w, h)
        S, T = np.meshgrid(np.linspace(0, 1, ns + 1), np.linspace(0, 1, nt + 1))
        verts.append(fn(S, T).reshape(-1, 3))
        uvs.append(np.stack([(cx + PAD + S * iw) / ATLAS_WIDTH,          # Mitsuba: v = row / height
                             (cy + PAD + (1 - T) * ih) / height], -1).reshape(-1, 2))
        quads = grid_faces(nt, ns)
        p = verts[-1]
        area = np.linalg.norm(np.cross(p[quads[:, 1]] - p[quads[:, 0]], p[quads[:, 2]] - p[quads[:, 0]]), axis=1)
        faces.append(quads[area > 1e-12] + n)               # the caps' centre row is degenerate
        n += len(p)
    v = normalise(np.concatenate(verts), up_axis=2)
    return v, np.concatenate(faces), np.concatenate(uvs), (np.clip(tex, 0, 1) * 255 + 0.5).astype(np.uint8)


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
