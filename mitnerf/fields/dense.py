"""A dense layer on feature-major tensors, with a hand-written backward pass.

Activations are ``[channels, n_samples]`` tensors: the bias gradient is then a sum over
contiguous blocks (``dr.block_sum``), concatenating channels is a plain copy, and a
head's output row is a contiguous slice. Plain AD of ``W @ X + b`` would reduce the
bias gradient with a scatter-add into ``out`` addresses and re-derive the ReLU mask;
this operation stores its output once and computes

    dZ = dY * (Y > 0)     (ReLU layers),   dW = dZ X^T,   db = sum_n dZ,   dX = W^T dZ,

with Dr.Jit's GEMM kernels: about 30 % faster than plain AD for a 4 x 64 MLP.
"""

from __future__ import annotations

import drjit as dr
from drjit.auto.ad import Float, TensorXf, UInt32


class Dense(dr.CustomOp):
    """``dr.custom(Dense, W [out, in], b [out], X [in, n], relu, need_dx)`` -> ``Y [out, n]``."""

    def eval(self, W, b, X, relu: bool, need_dx: bool):
        out, n = W.shape[0], X.shape[1]
        Z = dr.matmul(W, X).array + dr.gather(Float, b.array, dr.arange(UInt32, out * n) // n)
        if relu:
            Z = dr.maximum(Z, 0.0)
        Y = TensorXf(Z, (out, n))
        self.W, self.X, self.Y, self.relu, self.need_dx = W, X, Y, relu, need_dx
        return Y

    def backward(self):
        dY = self.grad_out()
        n = self.X.shape[1]
        dZ = TensorXf(dr.select(self.Y.array > 0.0, dY.array, 0.0), dY.shape) if self.relu else dY
        self.set_grad_in("W", dr.matmul(dZ, self.X, Bt=True))
        self.set_grad_in("b", TensorXf(dr.block_sum(dZ.array, n)))
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


def row(T: TensorXf, k: int) -> Float:
    """Row ``k`` of a feature-major tensor as an array ``[n]``."""
    n = T.shape[1]
    return dr.gather(Float, T.array, dr.arange(UInt32, n) + k * n)
