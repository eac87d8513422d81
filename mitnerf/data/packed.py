"""Views held compressed: the splits a fit only renders against (validation and test views) need their pixels a
few views at a time, so they are held as each view's 8-bit straight colour and coverage, compressed losslessly
(zlib), and unpacked per view where they are used. The views unpack to exactly the bytes packed."""

from __future__ import annotations

import zlib

import numpy as np

LEVEL = 1
"""zlib's compression level: the fastest, since the views are packed once per fit and unpacked per evaluation."""


class Packed:
    """``n`` views of 8-bit straight colour ``[H, W, 3]`` and coverage ``[H, W]``, each held as one zlib stream of
    its ``[H, W, 4]`` bytes, with each view's smallest coverage (what :attr:`alpha_min` tells without unpacking)."""

    def __init__(self, streams: list[bytes], size: tuple[int, int], alpha_min: np.ndarray):
        self.streams, self.size, self.alpha_min = streams, size, alpha_min
        """``alpha_min [n]`` (uint8): each view's smallest coverage."""

    @classmethod
    def of(cls, rgb8: np.ndarray, a8: np.ndarray) -> "Packed":
        """Pack ``rgb8 [n, H, W, 3]`` and ``a8 [n, H, W]`` (uint8), a view at a time."""
        streams = [zlib.compress(np.concatenate([c, a[..., None]], -1).tobytes(), LEVEL) for c, a in zip(rgb8, a8)]
        return cls(streams, a8.shape[1:], a8.reshape(len(a8), -1).min(1) if len(a8) else np.zeros(0, np.uint8))

    def __len__(self) -> int:
        return len(self.streams)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """The colour's shape, ``(n, H, W, 3)``."""
        return (len(self), *self.size, 3)

    @property
    def nbytes(self) -> int:
        """Bytes held."""
        return sum(len(s) for s in self.streams) + self.alpha_min.nbytes

    def take(self, index=None) -> tuple[np.ndarray, np.ndarray]:
        """The views ``index`` (all for None; an int, a slice or indices) unpacked: ``rgb8 [k, H, W, 3]``,
        ``a8 [k, H, W]``."""
        picked = np.arange(len(self))[slice(None) if index is None else index]
        out = np.empty((picked.size, *self.size, 4), np.uint8)
        for k, i in enumerate(np.atleast_1d(picked)):
            out[k] = np.frombuffer(zlib.decompress(self.streams[i]), np.uint8).reshape(*self.size, 4)
        if np.ndim(picked) == 0:
            return out[0, ..., :3], out[0, ..., 3]
        return out[..., :3], out[..., 3]

    def subset(self, index) -> "Packed":
        """The views ``index`` (indices, a slice or booleans), still packed."""
        picked = np.atleast_1d(np.arange(len(self))[index])
        return Packed([self.streams[i] for i in picked], self.size, self.alpha_min[picked])
