"""View harmonics: the colour of a lattice vertex as a function of the view direction, in the dense grid and the
linearly decoded hash grid (:mod:`.grid`, :mod:`.hashlinear`). Twin: :mod:`mitnerf.reference.fields.harmonics`."""

from __future__ import annotations

from .base import sigmoid


def view_basis(d: list, degree: int) -> list:
    """Harmonics of a unit view direction up to ``degree``; works on Dr.Jit arrays and torch tensors alike.
    2D ``d = (cos t, sin t)``: ``1, cos t, sin t, cos 2t, sin 2t, ...`` (any degree, by the angle-addition
    formulas); 3D (degree 1 or 2): ``1, x, y, z, xy, yz, 3z^2 - 1, xz, x^2 - y^2``."""
    out = [d[0] * 0 + 1, *d]
    if len(d) == 2:
        c, s = d
        ck, sk = c, s
        for _ in range(degree - 1):
            ck, sk = ck * c - sk * s, sk * c + ck * s
            out += [ck, sk]
    elif degree >= 2:
        x, y, z = d
        out += [x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y]
    return out


def harmonic_rgb(raw: list, d: list, K: int, degree: int, grey: bool = False) -> list:
    """RGB from raw colour coefficients at unit view directions ``d``: ``3 K`` (channel-major), the harmonics'
    weighted sum per channel (none when ``K`` is 1); ``grey``: ``3 + K - 1``, each channel's own degree-0 term plus
    one weighted sum of the other harmonics shared by all three. Then a sigmoid. Dr.Jit arrays."""
    if K > 1:
        basis = view_basis(list(d), degree)
        if grey:
            shared = sum(raw[2 + k] * basis[k] for k in range(1, K))
            raw = [raw[c] + shared for c in range(3)]
        else:
            raw = [sum(raw[c * K + k] * basis[k] for k in range(K)) for c in range(3)]
    return [sigmoid(r) for r in raw]
