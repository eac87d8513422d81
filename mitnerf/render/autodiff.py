"""The volume integral in plain automatic differentiation: all samples flat, block
prefix sums for the transmittance. Kept as the check on :mod:`.integral` (and for
forward-mode derivatives); it stores every per-sample intermediate for the backward pass.
"""

from __future__ import annotations

import drjit as dr
from drjit.auto.ad import Float

from .integral import RenderOutput


def integrate_autodiff(sigma: Float, rgb: list, t: Float, delta: Float, N: int, background) -> RenderOutput:
    """Ray-major samples (``[n_rays * N]`` each) -> per-ray colour, depth, opacity, weights."""
    sd = sigma * delta
    T = dr.exp(-dr.block_prefix_sum(sd, N, exclusive=True))     # T_i
    w = T * (1.0 - dr.exp(-sd))
    T_end = dr.exp(-dr.block_sum(sd, N))
    C = [dr.block_sum(w * c, N) + T_end * b for c, b in zip(rgb, background)]
    return RenderOutput(C, dr.block_sum(w * t, N), 1.0 - T_end, w)
