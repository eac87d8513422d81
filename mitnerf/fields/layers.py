"""Named linear layers in one of two evaluation modes, shared by the MLP-based fields.

``coopvec``: all weights packed into one buffer (``params['mlp']``), evaluated with
``drjit.nn`` cooperative vectors, traceable inside loops. ``tensor``: one tensor per
weight and bias (``params['<layer>.weight']``), evaluated on feature-major
``[channels, n]`` tensors with :func:`mitnerf.fields.dense.dense`. The canonical
numpy form (checkpoints, the torch twins) is the same for both: ``<layer>.weight
[out, in]`` and ``<layer>.bias [out]``, as ``torch.nn.Linear``.
"""

from __future__ import annotations

import drjit as dr
import drjit.nn as nn
import numpy as np
from drjit.auto.ad import Float, TensorXf

from ..errors import CheckpointError
from .dense import dense, row, stack_rows


def torch_default_init(shapes, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """U(-1/sqrt(in), 1/sqrt(in)) for weights and biases, as ``torch.nn.Linear``."""
    out = {}
    for name, o, i in shapes:
        k = 1.0 / np.sqrt(i)
        out[f"{name}.weight"] = rng.uniform(-k, k, (o, i)).astype(np.float32)
        out[f"{name}.bias"] = rng.uniform(-k, k, o).astype(np.float32)
    return out


def check_shapes(shapes, arrays: dict) -> None:
    """Refuse canonical weights that do not fit the layers ``shapes``."""
    for name, o, i in shapes:
        w, b = np.asarray(arrays[f"{name}.weight"]), np.asarray(arrays[f"{name}.bias"])
        if w.shape != (o, i) or b.shape != (o,):
            raise CheckpointError(f"{name}: expected weight {(o, i)} and bias {(o,)}, got {w.shape}, {b.shape}; "
                                  "the checkpoint was saved with another architecture")


class LinearLayers:
    """Storage and evaluation of the layers ``shapes = [(name, out, in), ...]``."""

    def __init__(self, shapes: list[tuple[str, int, int]], mode: str):
        if mode not in ("coopvec", "tensor"):
            raise ValueError(f"mode must be coopvec or tensor, got {mode!r}")
        self.shapes = list(shapes)
        self.mode = mode
        self.index = {name: k for k, (name, _, _) in enumerate(self.shapes)}
        self._view_specs = None

    # ------------------------------------------------------------------ storage
    def from_numpy(self, arrays: dict) -> dict:
        check_shapes(self.shapes, arrays)
        mats = []
        for name, _, _ in self.shapes:
            w, b = np.asarray(arrays[f"{name}.weight"]), np.asarray(arrays[f"{name}.bias"])
            mats += [TensorXf(w.astype(np.float32)), TensorXf(b.astype(np.float32))]
        if self.mode == "tensor":
            names = [f"{n}.{k}" for n, _, _ in self.shapes for k in ("weight", "bias")]
            return dict(zip(names, mats))
        views = nn.pack(*mats, layout="training")
        self._view_specs = [(v.dtype, v.offset, v.stride, v.size, v.layout, v.transpose, v.shape) for v in views]
        return {"mlp": Float(views[0].buffer)}

    def to_numpy(self, params: dict) -> dict[str, np.ndarray]:
        if self.mode == "tensor":
            return {f"{n}.{k}": np.array(params[f"{n}.{k}"], dtype=np.float32)
                    for n, _, _ in self.shapes for k in ("weight", "bias")}
        flat = nn.unpack(*self._views(params["mlp"]))
        out = {}
        for k, (name, o, i) in enumerate(self.shapes):
            out[f"{name}.weight"] = np.array(TensorXf(flat[2 * k]), dtype=np.float32).reshape(o, i)
            out[f"{name}.bias"] = np.array(TensorXf(flat[2 * k + 1]), dtype=np.float32).reshape(o)
        return out

    def _views(self, buffer) -> list:
        if self._view_specs is None:     # learn the packed layout once
            self.from_numpy({f"{n}.{k}": np.zeros((o, i) if k == "weight" else (o,), np.float32)
                             for n, o, i in self.shapes for k in ("weight", "bias")})
        views = []
        for dtype, offset, stride, size, layout, transpose, shape in self._view_specs:
            v = nn.MatrixView()
            v.dtype, v.offset, v.stride, v.size = dtype, offset, stride, size
            v.layout, v.transpose, v.shape = layout, transpose, shape
            v.buffer = buffer
            views.append(v)
        return views

    # ------------------------------------------------------------------ evaluation
    def start(self, cols: list):
        """Arrays ``[n]`` -> the mode's activation type."""
        return nn.CoopVec(cols) if self.mode == "coopvec" else stack_rows(cols)

    def concat(self, h, cols: list):
        """Append more input channels (a skip connection, an encoded direction)."""
        if not cols:
            return h
        if self.mode == "coopvec":
            return nn.CoopVec(*h, *cols)
        extra = stack_rows(cols)
        return TensorXf(dr.concat([h.array, extra.array]), (h.shape[0] + extra.shape[0], h.shape[1]))

    def linear(self, params: dict, name: str, h, relu: bool):
        if self.mode == "coopvec":
            k = self.index[name]
            v = self._views(params["mlp"])
            y = nn.matvec(v[2 * k], h, v[2 * k + 1])
            return dr.maximum(y, 0.0) if relu else y
        return dense(params[f"{name}.weight"], params[f"{name}.bias"], h, relu)

    def split(self, h, count: int | None = None) -> list:
        """The activation's channels as arrays ``[n]`` (the first ``count`` of them)."""
        if self.mode == "coopvec":
            out = list(h)
            return out if count is None else out[:count]
        n = h.shape[0] if count is None else count
        return [row(h, k) for k in range(n)]
