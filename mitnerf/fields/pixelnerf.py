"""pixelNeRF in 2D (Yu et al. 2021): a field that reads the scene from ``V`` input views
(the *context*) and is trained across scenes, so that a few views of a new scene render it.

**Encoder.** A 1D CNN over each input view (an ``H``-pixel RGB line): one convolution per
entry of ``dilations`` (zero padding, ReLU; receptive field ``1 + (kernel - 1) * sum(dilations)``
pixels), each an im2col gather and a dense layer. A pixel's feature concatenates every layer's
output (as NeRF2D), after the raw RGB when ``include_rgb``.

**Network.** A query point is projected into every input view (:func:`project`, as
:meth:`mitnerf.data.cameras.Cameras.project`) and the feature map interpolated there
(:func:`lookup`; zero features and validity 0 behind a camera or outside its image). Per view
``v`` the MLP input is ``[feature, valid, gamma(R_v^T x / bound), harmonics(R_v^T d)]``: point and
direction in the camera's axes (the field is equivariant to turning scene and cameras together about the origin).
``view_layers`` ReLU layers give per-view codes, pooled over the views (``pool``); ``head_layers``
ReLU layers then a linear layer give the raw density and colour. Samples and views are ordered
``sample * V + view``.

``field.with_context(ctx)`` (:func:`make_context`) conditions the field on input views; the
trainable ``params`` stay with the caller, as for every field.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Bool, Float, Int32, TensorXf, UInt32

from ..errors import MitnerfError
from ..settings import setting
from .base import Field, FieldConfig, density_activation, sigmoid
from .encoding import angle_harmonics, positional_encoding
from .layers import concat_rows, dense, row, stack_rows, torch_default_init

ENCODERS = ("frozen", "trained")
POOLS = ("mean", "mean_var")


@dataclass
class PixelNeRFConfig(FieldConfig):
    """Architecture of the 2D pixelNeRF field."""

    encoder: str = setting("trained", choices=ENCODERS)
    """``frozen`` (random weights, never updated; NeRF2D) or ``trained`` (learnt end to end)."""
    channels: int = setting(16, lo=1, hi=1024)
    """Filters per convolution layer."""
    dilations: tuple = setting((1, 2, 4, 8), lo=1, hi=1024)
    """Dilation of each convolution layer (its length is the number of layers)."""
    kernel: int = setting(3, lo=1, hi=63)
    """Convolution kernel size (odd)."""
    include_rgb: bool = setting(True)
    """Put the raw pixel colour in front of the CNN features."""
    encoder_seed: int = setting(1234, lo=0, hi=2 ** 32 - 1)
    """Seed of the frozen encoder's random weights."""
    pos_L: int = setting(6, lo=0, hi=24, flag="--pos-L")
    """Frequencies of the positional encoding of the point (in each camera's axes)."""
    dir_L: int = setting(2, lo=0, hi=12, flag="--dir-L")
    """Angle harmonics of the query direction (in each camera's axes)."""
    width: int = setting(64, lo=2, hi=1024, flag="--mlp-width")
    """MLP units per layer."""
    view_layers: int = setting(2, lo=1, hi=32)
    """ReLU layers applied per input view, before the average over views."""
    head_layers: int = setting(2, lo=0, hi=32)
    """ReLU layers after the average, before the linear output layer."""
    pool: str = setting("mean_var", choices=POOLS)
    """How per-view codes are combined: ``mean`` (pixelNeRF) or ``mean_var`` (mean and variance
    over views, as IBRNet: agreement between views becomes an explicit input of the head)."""
    density_bias: float = setting(-1.0, lo=-1e3, hi=1e3)
    """Added to the density output's initial bias: a slightly transparent start."""
    bound: float = setting(1.8, lo=0, above=True, hi=1e6)
    """As every field's; positions are divided by it before encoding."""

    def settle(self) -> None:
        """2D only, an odd kernel, whole dilations."""
        self.dilations = tuple(int(d) for d in self.dilations)
        if self.dim != 2:
            raise MitnerfError("pixelNeRF is implemented for 2D scenes (1D views) only")
        if self.kernel % 2 != 1:
            raise MitnerfError(f"the convolution kernel must be odd (same-size output), got {self.kernel}")

    @property
    def feature_size(self) -> int:
        """Channels of a pixel feature."""
        return (3 if self.include_rgb else 0) + self.channels * len(self.dilations)

    @property
    def input_size(self) -> int:
        """Rows of the per-view MLP input: feature, valid flag, encoded point, direction."""
        return self.feature_size + 1 + 2 * (1 + 2 * self.pos_L) + 2 * self.dir_L


def encoder_shapes(cfg: PixelNeRFConfig) -> list[tuple[str, int, int]]:
    """``(name, out, in)`` of each convolution as a dense layer (``in = C_in * kernel``)."""
    return [(f"enc.{i}", cfg.channels, (cfg.channels if i else 3) * cfg.kernel) for i in range(len(cfg.dilations))]


def mlp_shapes(cfg: PixelNeRFConfig) -> list[tuple[str, int, int]]:
    pooled = cfg.width * (2 if cfg.pool == "mean_var" else 1)
    return ([(f"view.{i}", cfg.width, cfg.width if i else cfg.input_size) for i in range(cfg.view_layers)]
            + [(f"head.{i}", cfg.width, cfg.width if i else pooled) for i in range(cfg.head_layers)]
            + [("out", 4, cfg.width if cfg.head_layers else pooled)])


def encoder_weights(cfg: PixelNeRFConfig, seed: int) -> dict[str, np.ndarray]:
    """He-normal convolution weights (std sqrt(2 / fan_in)), zero biases."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, o, i in encoder_shapes(cfg):
        out[f"{name}.weight"] = (rng.standard_normal((o, i)) * np.sqrt(2.0 / i)).astype(np.float32)
        out[f"{name}.bias"] = np.zeros(o, np.float32)
    return out


def mlp_weights(cfg: PixelNeRFConfig, seed: int) -> dict[str, np.ndarray]:
    """PyTorch's ``nn.Linear`` default, U(+-1/sqrt(in)) for weights and biases."""
    out = torch_default_init(mlp_shapes(cfg), np.random.default_rng(seed))
    out["out.bias"][0] += np.float32(cfg.density_bias)
    return out


def im2col(X: TensorXf, H: int, K: int, dilation: int) -> TensorXf:
    """Columns of a 1D convolution: ``X [C, V*H]`` (V views of H pixels, view-major) ->
    ``[C*K, V*H]`` with row ``c*K + k`` = channel ``c`` shifted by ``(k - K//2) * dilation``
    pixels inside its own view (zero outside it). Differentiable (a gather)."""
    C, VH = X.shape
    idx = dr.arange(UInt32, C * K * VH)
    col, ck = idx % VH, idx // VH
    c, k = ck // K, ck % K
    shift = Int32(k) * dilation - (K // 2) * dilation
    src = Int32(col % H) + shift                                 # pixel inside the view
    ok = (src >= 0) & (src < H)
    addr = UInt32(Int32(c * VH + col) + dr.select(ok, shift, 0))
    return TensorXf(dr.gather(Float, X.array, addr, ok), (C * K, VH))


def conv1d(W: TensorXf, b: TensorXf, X: TensorXf, H: int, dilation: int, relu: bool = True) -> TensorXf:
    """``relu?(conv1d(X))`` with weights ``W [C_out, C_in*K]`` (row-major ``[C_out, C_in, K]``)."""
    K = W.shape[1] // X.shape[0]
    return dense(W, b, im2col(X, H, K, dilation), relu)


def encode(cfg: PixelNeRFConfig, weights: dict, images: TensorXf, H: int) -> TensorXf:
    """Pixel features ``[feature_size, V*H]`` of images ``[3, V*H]``."""
    parts = [images] if cfg.include_rgb else []
    h = images
    for i, dil in enumerate(cfg.dilations):
        h = conv1d(weights[f"enc.{i}.weight"], weights[f"enc.{i}.bias"], h, H, dil)
        parts.append(h)
    return concat_rows(parts)


CAM_FLOATS = 6
"""Per input view: origin (x, y), forward (x, y), up (x, y)."""


def project(x: list, cams: Float, view: UInt32, H: int, focal: float):
    """Project points ``x`` (2 arrays ``[m]``) into input ``view`` ``[m]`` of ``cams``: ``(row, forward, valid)``,
    the continuous image row (pixel centre ``i`` at ``i + 0.5``), the distance along the camera axis, and
    whether the point is in front of the camera and inside the image (``0 <= row <= H``)."""
    g = lambda k: dr.gather(Float, cams, view * CAM_FLOATS + k)
    rx, ry = x[0] - g(0), x[1] - g(1)
    fwd = rx * g(2) + ry * g(3)
    up = rx * g(4) + ry * g(5)
    front = fwd > 1e-4
    r = H * 0.5 - focal * up / dr.select(front, fwd, 1.0)
    valid = front & (r >= 0.0) & (r <= float(H))
    return dr.select(valid, r, 0.5), fwd, valid


def lookup(features: TensorXf, view: UInt32, r: Float, valid, H: int) -> TensorXf:
    """Features ``[C, V*H]`` linearly interpolated at rows ``r`` of ``view`` (each ``[m]``)
    -> ``[C, m]``; zero where not ``valid``. Rows before the first or after the last pixel
    centre take that pixel's feature."""
    C, VH = features.shape
    m = dr.width(r)
    p = r - 0.5                                                  # pixel-centre coordinates
    i0 = Int32(dr.floor(p))
    idx = dr.arange(UInt32, C * m)
    c, j = idx // m, idx % m
    ok = dr.gather(Bool, valid, j)
    a0, a1 = (view * H + UInt32(dr.clip(i, 0, H - 1)) for i in (i0, i0 + 1))   # the pixels on either side
    f0, f1 = (dr.gather(Float, features.array, c * VH + dr.gather(UInt32, a, j), ok) for a in (a0, a1))
    w = dr.gather(Float, p - dr.floor(p), j)
    return TensorXf(f0 + w * (f1 - f0), (C, m))


@dataclass
class Context:
    """The input views a field is conditioned on (Dr.Jit arrays)."""

    images: TensorXf
    """Colours ``[3, V*H]`` (display space over the background), view-major columns."""
    cams: Float
    """``[V * 6]``: origin, forward axis, up axis of each view (world)."""
    n_views: int
    height: int
    focal: float
    features: TensorXf | None = None
    """Precomputed pixel features ``[feature_size, V*H]`` (frozen encoder), else None."""


def make_context(images: np.ndarray, poses: np.ndarray, focal: float, features: np.ndarray | None = None) -> Context:
    """A context from numpy views ``images [V, H, 3]`` (or ``[V, H, 1, 3]``) and 2D poses ``[V, 3, 3]``."""
    poses = np.asarray(poses)
    images = np.asarray(images, np.float32).reshape(len(poses), -1, 3)
    V, H = images.shape[:2]
    img = TensorXf(np.ascontiguousarray(images.transpose(2, 0, 1).reshape(3, V * H)))
    cams = np.concatenate([poses[:, :2, 2], poses[:, :2, 0], poses[:, :2, 1]], 1)    # origin, forward, up
    feats = None if features is None else TensorXf(np.ascontiguousarray(features, dtype=np.float32))
    return Context(img, Float(cams.astype(np.float32).ravel()), V, H, float(focal), feats)


class PixelNeRFField(Field):
    def __init__(self, cfg: PixelNeRFConfig, context: Context | None = None):
        super().__init__(cfg)
        self.context = context
        frozen = encoder_weights(cfg, cfg.encoder_seed)
        self.frozen = {k: TensorXf(v) for k, v in frozen.items()} if cfg.encoder == "frozen" else None

    def with_context(self, context: Context) -> "PixelNeRFField":
        """The same field conditioned on ``context`` (a shallow copy)."""
        other = copy.copy(self)
        other.context = context
        return other

    def init_numpy(self, seed: int = 0) -> dict:
        trained = encoder_weights(self.cfg, self.cfg.encoder_seed) if self.cfg.encoder == "trained" else {}
        return {**mlp_weights(self.cfg, seed), **trained}

    def from_numpy(self, arrays: dict) -> dict:
        return {k: TensorXf(np.asarray(v, np.float32)) for k, v in arrays.items()}

    def to_numpy(self, params: dict) -> dict:
        return {k: np.array(v, dtype=np.float32) for k, v in params.items()}

    def features(self, params: dict, context: Context | None = None) -> TensorXf:
        """Pixel features of the context views ``[feature_size, V*H]``."""
        ctx = context or self.context
        if ctx.features is not None:
            return ctx.features
        return encode(self.cfg, self.frozen if self.frozen is not None else params, ctx.images, ctx.height)

    def features_numpy(self, images: np.ndarray) -> np.ndarray:
        """Frozen-encoder features of numpy views ``[V, H, 3]`` -> ``[feature_size, V*H]``
        (compute once per view; put them in :func:`make_context`)."""
        if self.frozen is None:
            raise MitnerfError("features_numpy precomputes frozen features; this field trains its encoder "
                               "(use encoder='frozen', or let query() encode the views)")
        ctx = make_context(images, np.tile(np.eye(3), (len(images), 1, 1)), 1.0)
        with dr.suspend_grad():
            return np.array(encode(self.cfg, self.frozen, ctx.images, ctx.height), dtype=np.float32)

    def density(self, params: dict, x) -> Float:
        """Density at ``x`` seen from outside: along ``-x / |x|`` (the query direction is an
        input of every view's MLP, as in pixelNeRF, so density needs one)."""
        inv = dr.rsqrt(dr.maximum(x[0] * x[0] + x[1] * x[1], 1e-12))
        return self.query(params, x, [-x[0] * inv, -x[1] * inv])[0]

    def query(self, params: dict, x, d, keep=None):
        """Density ``[n]`` and colour (3 x ``[n]``) at points ``x`` seen along ``d``."""
        ctx = self.context
        if ctx is None:
            raise MitnerfError("this pixelNeRF field has no input views; call field.with_context(make_context(...))")
        cfg, V, H = self.cfg, ctx.n_views, ctx.height
        n = dr.width(x[0])
        idx = dr.arange(UInt32, n * V)
        s, view = idx // V, idx % V                               # sample-major, view-minor
        xs = [dr.gather(Float, xi, s) for xi in x]
        ds = [dr.gather(Float, di, s) for di in d]
        r, _, valid = project(xs, ctx.cams, view, H, ctx.focal)
        F = lookup(self.features(params, ctx), view, r, valid, H)   # [F, n*V]
        fx, fy, ux, uy = (dr.gather(Float, ctx.cams, view * CAM_FLOATS + k) for k in range(2, 6))
        inv_b = 1.0 / cfg.bound
        q = [(xs[0] * fx + xs[1] * fy) * inv_b, (xs[0] * ux + xs[1] * uy) * inv_b]   # point in camera axes
        dq = [ds[0] * fx + ds[1] * fy, ds[0] * ux + ds[1] * uy]                      # direction in camera axes
        rows = [dr.select(valid, 1.0, 0.0)] + positional_encoding(q, cfg.pos_L) + angle_harmonics(dq, cfg.dir_L)
        h = concat_rows([F, stack_rows(rows)])                    # [input_size, n*V]
        for i in range(cfg.view_layers):
            h = dense(params[f"view.{i}.weight"], params[f"view.{i}.bias"], h, True)
        pooled = [dr.block_sum(h.array, V) * (1.0 / V)]          # [width * n]: mean over views (and variance)
        if cfg.pool == "mean_var":
            pooled.append(dr.maximum(dr.block_sum(dr.square(h.array), V) * (1.0 / V) - dr.square(pooled[0]), 0.0))
        h = TensorXf(dr.concat(pooled), (len(pooled) * cfg.width, n))
        for i in range(cfg.head_layers):
            h = dense(params[f"head.{i}.weight"], params[f"head.{i}.bias"], h, True)
        out = dense(params["out.weight"], params["out.bias"], h, False)     # [4, n]
        return density_activation(row(out, 0), cfg.density_activation), [sigmoid(row(out, k)) for k in (1, 2, 3)]
