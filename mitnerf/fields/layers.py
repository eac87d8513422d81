"""Linear layers for the MLP-based fields: :func:`dense` on feature-major tensors, and named
layers stored in one of three modes.

``coopvec``: all weights packed into one buffer (``params['mlp']``), evaluated with
``drjit.nn`` cooperative vectors, traceable inside loops. ``tensor``: one tensor per
weight and bias (``params['<layer>.weight']``), evaluated on feature-major
``[channels, n]`` tensors with :func:`dense`. ``native``: the canonical
arrays concatenated in one flat buffer (``params['mlp']``) for :mod:`.native` (storage only).
The canonical numpy form (checkpoints, the torch twins) is the same for all: ``<layer>.weight
[out, in]`` and ``<layer>.bias [out]``, as ``torch.nn.Linear``.

:class:`Dense` has a hand-written backward: on ``[channels, n]`` tensors the bias gradient is a
``dr.block_sum`` (plain AD: a scatter-add) and the ReLU mask is read from the stored output (``mlp_ms.tensor``
of ``step_time/w32`` and ``step_time/w128`` measures the tensor mode)::

    dZ = dY * (Y > 0)     (ReLU layers),   dW = dZ X^T,   db = sum_n dZ,   dX = W^T dZ
"""

from __future__ import annotations

import math

import drjit as dr
import drjit.nn as nn
import numpy as np
from drjit.auto.ad import Float, TensorXf, UInt32

from ..errors import CheckpointError


class Dense(dr.CustomOp):
    """``dr.custom(Dense, W [out, in], b [out], X [in, n], relu, need_dx)`` -> ``Y [out, n]``."""

    def eval(self, W, b, X, relu: bool, need_dx: bool):
        out, n = W.shape[0], X.shape[1]
        Z = dr.matmul(W, X).array + dr.gather(Float, b.array, dr.arange(UInt32, out * n) // n)
        Y = TensorXf(dr.maximum(Z, 0.0) if relu else Z, (out, n))
        self.W, self.X, self.Y, self.relu, self.need_dx = W, X, Y, relu, need_dx
        return Y

    def backward(self):
        dY = self.grad_out()
        dZ = TensorXf(dr.select(self.Y.array > 0.0, dY.array, 0.0), dY.shape) if self.relu else dY
        self.set_grad_in("W", dr.matmul(dZ, self.X, Bt=True))
        self.set_grad_in("b", TensorXf(dr.block_sum(dZ.array, self.X.shape[1])))
        if self.need_dx:
            self.set_grad_in("X", dr.matmul(self.W, dZ, At=True))

    def name(self):
        return "Dense"


def dense(W: TensorXf, b: TensorXf, X: TensorXf, relu: bool) -> TensorXf:
    """``relu?(W @ X + b)`` for feature-major ``X [in, n]``."""
    return dr.custom(Dense, W, b, X, relu, dr.grad_enabled(X))


def stack_rows(cols: list) -> TensorXf:
    """C arrays ``[n]`` -> a feature-major tensor ``[C, n]`` (differentiable)."""
    return TensorXf(dr.concat(cols), (len(cols), dr.width(cols[0])))


def concat_rows(parts: list) -> TensorXf:
    """Stack feature-major tensors ``[C_i, n]`` into ``[sum C_i, n]``."""
    if len(parts) == 1:
        return parts[0]
    return TensorXf(dr.concat([p.array for p in parts]), (sum(p.shape[0] for p in parts), parts[0].shape[1]))


def row(T: TensorXf, k: int) -> Float:
    """Row ``k`` of a feature-major tensor as an array ``[n]``."""
    n = T.shape[1]
    return dr.gather(Float, T.array, dr.arange(UInt32, n) + k * n)


def torch_default_init(shapes, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """U(-1/sqrt(in), 1/sqrt(in)) for weights and biases, as ``torch.nn.Linear``."""
    return {f"{n}.{k}": rng.uniform(-1.0 / np.sqrt(i), 1.0 / np.sqrt(i), s).astype(np.float32)
            for n, o, i in shapes for k, s in (("weight", (o, i)), ("bias", o))}


class LinearLayers:
    """Storage and evaluation of the layers ``shapes = [(name, out, in), ...]``."""

    def __init__(self, shapes: list[tuple[str, int, int]], mode: str):
        self.shapes, self.mode = list(shapes), mode
        self.canonical = {f"{n}.{k}": s for n, o, i in shapes for k, s in (("weight", (o, i)), ("bias", (o,)))}
        self.index = {name: k for k, (name, _, _) in enumerate(self.shapes)}
        self._view_specs = None

    def from_numpy(self, arrays: dict) -> dict:
        for name, o, i in self.shapes:
            w, b = np.asarray(arrays[f"{name}.weight"]), np.asarray(arrays[f"{name}.bias"])
            if w.shape != (o, i) or b.shape != (o,):
                raise CheckpointError(f"{name}: expected weight {(o, i)} and bias {(o,)}, got {w.shape}, {b.shape}; "
                                      "the checkpoint was saved with another architecture")
        mats = [np.asarray(arrays[k]).astype(np.float32) for k in self.canonical]
        if self.mode == "native":
            return {"mlp": Float(np.concatenate([m.ravel() for m in mats]))}
        if self.mode == "tensor":
            return {k: TensorXf(m) for k, m in zip(self.canonical, mats)}
        views = nn.pack(*map(TensorXf, mats), layout="training")
        self._view_specs = [(v.dtype, v.offset, v.stride, v.size, v.layout, v.transpose, v.shape) for v in views]
        return {"mlp": Float(views[0].buffer)}

    def to_numpy(self, params: dict) -> dict[str, np.ndarray]:
        if self.mode == "tensor":
            flat = [params[k] for k in self.canonical]
        elif self.mode == "native":
            flat = np.split(np.asarray(params["mlp"]), np.cumsum([math.prod(s) for s in self.canonical.values()])[:-1])
        else:
            flat = [TensorXf(m) for m in nn.unpack(*self._views(params["mlp"]))]
        return {k: np.array(m, dtype=np.float32).reshape(s) for (k, s), m in zip(self.canonical.items(), flat)}

    def _views(self, buffer) -> list:
        if self._view_specs is None:     # learn the packed layout once
            self.from_numpy({k: np.zeros(s, np.float32) for k, s in self.canonical.items()})
        views = []
        for dtype, offset, stride, size, layout, transpose, shape in self._view_specs:
            v = nn.MatrixView()
            v.dtype, v.offset, v.stride, v.size = dtype, offset, stride, size
            v.layout, v.transpose, v.shape = layout, transpose, shape
            v.buffer = buffer
            views.append(v)
        return views

    # ------------------------------------------------------------------ evaluation (coopvec and tensor)
    def start(self, cols: list):
        """Arrays ``[n]`` -> the mode's activation type."""
        return nn.CoopVec(cols) if self.mode == "coopvec" else stack_rows(cols)

    def concat(self, h, cols: list):
        """Append more input channels (a skip connection, an encoded direction)."""
        if not cols:
            return h
        return nn.CoopVec(*h, *cols) if self.mode == "coopvec" else concat_rows([h, stack_rows(cols)])

    def linear(self, params: dict, name: str, h, relu: bool):
        if self.mode == "coopvec":
            k, v = 2 * self.index[name], self._views(params["mlp"])
            y = nn.matvec(v[k], h, v[k + 1])
            return dr.maximum(y, 0.0) if relu else y
        return dense(params[f"{name}.weight"], params[f"{name}.bias"], h, relu)

    def split(self, h, count: int | None = None) -> list:
        """The activation's channels as arrays ``[n]`` (the first ``count`` of them)."""
        if self.mode == "coopvec":
            return list(h)[:count]
        return [row(h, k) for k in range(h.shape[0] if count is None else count)]
