r"""Error-driven ray sampling, after soft mining (Kheradmand et al., CVPR 2024), from a map of tiles' errors;
engine-agnostic numpy.

The training pixels are cut into tiles of ``tile x tile`` pixels of one view. Each tile remembers the error
:math:`e_t` of the last ray drawn in it (the root mean square over the colour channels of the final pass's
residual), which stands for each of its pixels; a tile not drawn yet keeps :data:`UNSEEN`, above any error, so
the first draws sweep the tiles. A batch draws pixel *i*, in tile *t(i)*, with probability

.. math::  p_i = s\,\frac{e_{t(i)}}{\sum_j e_{t(j)}} + \frac{1 - s}{N},

(*s* the share given to the errors, *N* the pixels, the sum over every pixel): a tile *t* of :math:`n_t` pixels
(fewer at a view's border) with :math:`p_t = n_t\, p_i`, then a pixel uniformly inside it. Hard pixels
(silhouettes, fine texture) come back often, pixels already fitted (an empty background) seldom.

A ray's loss is weighted by :math:`w_i = (1 / (N p_i))^\alpha`, the uniform draw's chance over its own, and the
weights are divided by their mean over the batch: :math:`\alpha = 1` is importance sampling (the uniform loss's
estimate, unbiased), :math:`\alpha = 0` hard mining (the drawn rays as they come); between them, soft mining. The
uniform share bounds every weight, before the division, by :math:`(1 - s)^{-\alpha}`.

A checkpoint keeps the map and the errors not yet recorded in it (``Backend.sampling_state``): a resumed run draws
the batches the run would have drawn. ``benchmarks/lego.py`` measures the setting against uniform draws."""

from __future__ import annotations

import numpy as np

from ..rng import uniform_np

UNSEEN = 1.0
"""The error a tile holds until a ray is drawn in it: above any colour error in [0, 1]."""
MINING_SALT = 0x2545F491
"""Seed salt of the draws (:func:`mitnerf.rng.uniform_np`)."""


class ErrorMap:
    """Each tile's last error, the draws in proportion to it (:meth:`draw`) and their loss weights."""

    def __init__(self, shape: tuple[int, int, int], tile: int, share: float, alpha: float):
        """``shape``: the training pixels ``(views, H, W)``, flat index ``(view * H + row) * W + col``."""
        self.shape, self.tile, self.share, self.alpha = tuple(int(s) for s in shape), int(tile), share, alpha
        n, H, W = self.shape
        self.rows, self.cols = -(-H // self.tile), -(-W // self.tile)        # tiles a view, down and across
        self.n_pixels = n * H * W
        self.error = np.full(n * self.rows * self.cols, UNSEEN, np.float64)   # [T]
        tr, tc = np.arange(self.rows), np.arange(self.cols)
        heights = np.minimum(H - tr * self.tile, self.tile)
        widths = np.minimum(W - tc * self.tile, self.tile)
        self.height = np.tile(np.repeat(heights, self.cols), n)            # [T] rows of pixels in each tile
        self.width = np.tile(np.tile(widths, self.rows), n)                # [T] columns of pixels in each tile
        self.pixels = (self.height * self.width).astype(np.float64)        # [T]
        self._cdf = np.empty(len(self.error))                                # [T] the draws' running sum, reused

    def __len__(self) -> int:
        return len(self.error)

    def chance(self, error: np.ndarray, total: float) -> np.ndarray:
        """``p_i`` of pixels whose tiles hold ``error`` ``[m]``, with ``total`` the errors' sum over every pixel
        (uniform while every error is 0)."""
        share = self.share if total > 0 else 0.0
        return share * error / max(total, 1e-300) + (1.0 - share) / self.n_pixels

    def probabilities(self) -> np.ndarray:
        """``[T]``: the chance that a draw lands in each tile, ``n_t p_i``."""
        return self.pixels * self.chance(self.error, float(np.dot(self.error, self.pixels)))

    def draw(self, seed: int, batch: int) -> tuple[np.ndarray, np.ndarray]:
        """``(flat pixel indices [batch] int64, loss weights [batch] float32 of mean 1)`` of batch ``seed``: each ray
        from the errors with chance *s* (a tile by the errors' running sum, then a pixel in it), else a pixel
        uniformly; the errors' keys are searched in ascending order, which keeps the search in cache."""
        ray = np.arange(batch, dtype=np.uint32)
        u = [uniform_np(seed ^ MINING_SALT, ray, np.full(batch, k, np.uint32)).astype(np.float64) for k in range(4)]
        cdf = np.cumsum(np.multiply(self.error, self.pixels, out=self._cdf), out=self._cdf)   # [T] of e_t n_t
        total = float(cdf[-1])
        share = self.share if total > 0 else 0.0
        index = np.minimum((u[0] * self.n_pixels).astype(np.int64), self.n_pixels - 1)
        mined = np.flatnonzero(u[3] < share)
        if len(mined):
            t = np.searchsorted(cdf, np.sort(u[0][mined]) * total, side="right")
            t = np.minimum(t, len(cdf) - 1)
            h, w = self.height[t], self.width[t]
            view, rest = np.divmod(t, self.rows * self.cols)
            tr, tc = np.divmod(rest, self.cols)
            row = tr * self.tile + np.minimum((u[1][mined] * h).astype(np.int64), h - 1)
            col = tc * self.tile + np.minimum((u[2][mined] * w).astype(np.int64), w - 1)
            _, H, W = self.shape
            index[mined] = (view * H + row) * W + col
        p = self.chance(self.error[self.tile_of(index)], total)
        weight = (p * self.n_pixels) ** -self.alpha                                 # (1 / (N p_i))^alpha
        return index, (weight / weight.mean()).astype(np.float32)

    def tile_of(self, index: np.ndarray) -> np.ndarray:
        """``[m]`` tiles of flat pixel indices ``[m]``."""
        _, H, W = self.shape
        view, rest = np.divmod(np.asarray(index, np.int64), H * W)
        row, col = np.divmod(rest, W)
        return (view * self.rows + row // self.tile) * self.cols + col // self.tile

    def record(self, index: np.ndarray, error: np.ndarray) -> None:
        """Set the tiles of the rays at flat ``index`` ``[m]`` to their errors ``[m]`` (RMS colour residual;
        of two rays in one tile, the later one's)."""
        self.error[self.tile_of(index)] = finite(error)


def finite(error) -> np.ndarray:
    """Per-ray errors ``[m]`` as float64, a diverged ray's (NaN or infinite) read as :data:`UNSEEN`."""
    return np.nan_to_num(np.asarray(error, np.float64), nan=UNSEEN, posinf=UNSEEN)
