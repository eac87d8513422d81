"""Parity of every Dr.Jit path with the torch twin: the same weights, rays and random cotangents through the
custom volume integral (replayed adjoint; a CoopVec field fused into the march, a tensor-mode field on gathered
samples, the native MLP kernel), Dr.Jit's plain automatic differentiation and the PyTorch reference; field outputs,
colour, depth and opacity of both passes, the gradient of every weight and of the ray origins and directions; then
central differences on a tiny case (``examples/check_backends.py`` prints it).

fp32 tolerances, values against torch and gradients against plain AD: values max |err| <= 1e-5 (depths, O(5):
5e-5); gradients max |err| / max |reference| <= 5e-3, the slack for ReLU kinks (a pre-activation within rounding
of zero lands on either side in Dr.Jit's FMAs and torch's GEMMs, and that sample's gradient changes by a finite
step; bugs give 1e-2 and more); central differences (eps 1e-2, the 3 largest-gradient entries of every parameter
no ReLU follows, 3 rays x 8 samples) within 2e-2 x max(|grad|, |fd|, 10 % of the tensor's largest gradient).
Weights: the field's initialisation plus N(0, 0.3) noise on grid values and hash tables (they start constant or
near zero); networks keep theirs, since noise there puts pre-activations within the step of their kinks. In 3D the
same checks run in a forward-facing (NDC) or unbounded (contracted) scene's space (:data:`FRAMES`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import drjit as dr
import numpy as np
import torch
from drjit.auto.ad import Float, UInt32

from ..fields import make_field
from ..fields.native import library
from ..render.pipeline import RenderConfig, split_params
from ..render.samplers import Stratified
from ..render.volume import volume_render
from ..train.backend_drjit import build_model
from ..train.backend_torch import build_torch_model
from ..train.config import ModelConfig

TOL_VALUE, TOL_DEPTH, TOL_GRAD, TOL_FD = 1e-5, 5e-5, 5e-3, 2e-2
FIELD_ARGS = {   # small fields, each with view dependence
    "vanilla": dict(width=16, depth=4, pos_L=6, dir_L=3, density_bias=0.5),
    "grid": dict(resolution=17, view_dependent=True, tv_weight=0.0, density_init=0.5),
    "hashgrid": dict(n_levels=4, log2_hashmap_size=10, base_resolution=4, max_resolution=32, hidden=8,
                     geo_features=3, view_dependent=True, dir_L=2, density_activation="softplus", density_bias=0.5),
    "hashlinear": dict(resolutions=(5, 9, 17), dense_levels=1, log2_hashmap_size=6, view_levels=2, initial_levels=3,
                       tv_weight=0.0, tv_color_weight=0.0, density_init=0.5),
}
PATHS = {   # field -> (label, network mode or None, integral) of every Dr.Jit path
    "vanilla": [("custom op, coopvec field", "coopvec", "replay"), ("custom op, tensor field", "tensor", "replay"),
                ("custom op, native MLP", "native", "replay"), ("drjit plain AD", "tensor", "autodiff")],
    "grid": [("custom op, fused grid", None, "replay"), ("drjit plain AD", None, "autodiff")],
    "hashlinear": [("custom op, fused levels", None, "replay"), ("drjit plain AD", None, "autodiff")],
    "hashgrid": [("custom op, coopvec nets", "coopvec", "replay"), ("custom op, tensor nets", "tensor", "replay"),
                 ("drjit plain AD", "tensor", "autodiff")],
}
GRID_ARRAYS = ("density", "color", "table")
KINK_FREE = {"vanilla": ("sigma", "color.1"), "grid": ("density", "color"), "hashlinear": ("density", "color"),
             "hashgrid": ("table", "sigma_net.1", "color_net.1")}
"""Parameters no ReLU follows: moving them by the finite-difference step moves no kink, so central
differences in fp32 are exact to rounding (earlier layers are checked against plain AD and torch)."""
TORCH_NAMES = {"density_grid": "density", "color_grid": "color", "density_table": "density", "color_table": "color"}
FRAMES = {"object": {},
          "unbounded": dict(matrix=[[0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 0.5, 0]], bound=2.0, near=1.0, far=7.0,
                            knee=2.0),
          "forward": dict(matrix=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -4.5]], bound=1.0, near=1.0, far=7.0,
                          knee=1.0)}
"""The scenes the harness checks, and their frames (:func:`mitnerf.render.space.scene_frame`'s keys): the rays'
origins (radius 4) map outside the contraction's unit ball, and the NDC near plane lies at world ``z = 3.5``."""


def bound_of(mc: ModelConfig) -> float:
    return mc.render.frame.get("bound", 1.5)


@dataclass
class Parity:
    """Per quantity, each path's error: values against torch (max abs), gradients against plain AD (max abs / max
    |reference|); the custom op's worst relative error against central differences."""

    paths: list[str]
    values: dict[str, list[float]]
    grads: dict[str, list[float]]
    fd: float

    @property
    def ok(self) -> bool:
        return (all(e <= (TOL_DEPTH if "depth" in k else TOL_VALUE) for k, es in self.values.items() for e in es)
                and all(e <= TOL_GRAD for es in self.grads.values() for e in es) and self.fd <= TOL_FD)


def make_rays(dim: int, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Origins on the sphere of radius 4 and unit directions towards the centre, jittered: [n, dim] each."""
    rng = np.random.default_rng(seed)
    if dim == 2:
        a = rng.uniform(0, 2 * np.pi, n)
        o = np.stack([4 * np.cos(a), 4 * np.sin(a)], 1)
    else:
        v = rng.normal(size=(n, 3))
        o = 4 * v / np.linalg.norm(v, axis=1, keepdims=True)
    d = -o / 4 + rng.normal(0, 0.15, o.shape)
    return o.astype(np.float32), (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


def noisy(arrays: dict, rng) -> dict:
    """N(0, 0.3) noise on grid values and hash tables; network weights unchanged."""
    return {k: (v + rng.normal(0, 0.3, v.shape)).astype(np.float32) if k.split(".")[-1] in GRID_ARRAYS else v
            for k, v in arrays.items()}


def _probe(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """256 points in the field's box and directions: [256, dim] each."""
    pts = np.random.default_rng(5).uniform(-1.4, 1.4, (256, dim)).astype(np.float32)
    return pts, pts / np.linalg.norm(pts, axis=1, keepdims=True)


def run_drjit(model_cfg: ModelConfig, weights: dict, o, d, cot: dict, mode, method: str, seed: int):
    """One Dr.Jit path -> ({quantity: values}, {parameter or ray input: gradient})."""
    args = dict(model_cfg.field_args) if mode is None else {**model_cfg.field_args, "mode": mode}
    cfg = dataclasses.replace(model_cfg, field_args=args, render=dataclasses.replace(model_cfg.render, method=method))
    model = build_model(cfg, o.shape[1], bound_of(cfg))
    params = model.from_numpy(weights)
    O, D = [Float(c) for c in o.T], [Float(c) for c in d.T]
    dr.enable_grad(params, O, D)
    outs = model.render(params, O, D, 1.0, 7.0, UInt32(seed), training=True, input_grads=True)
    res, loss = {}, 0
    for name, c in cot.items():
        out = outs[name]
        res[f"{name} colour"] = np.stack([np.asarray(v) for v in out.rgb], 1)
        res[f"{name} depth"], res[f"{name} opacity"] = np.asarray(out.depth), np.asarray(out.opacity)
        loss = loss + sum(dr.sum(out.rgb[k] * Float(c["rgb"][:, k])) for k in range(3))
        loss = loss + dr.sum(out.depth * Float(c["depth"])) + dr.sum(out.opacity * Float(c["opacity"]))
    pts, dirs = _probe(o.shape[1])
    g = model.final_field()
    with dr.suspend_grad():
        s, c = model.fields[g].query(split_params(params, g), [Float(v) for v in pts.T], [Float(v) for v in dirs.T])
        res["field sigma"], res["field rgb"] = np.asarray(s), np.stack([np.asarray(v) for v in c], 1)
    dr.backward(loss)
    grads = model.to_numpy({k: dr.grad(v) for k, v in params.items()})
    grads["ray origins"] = np.stack([np.asarray(dr.grad(v)) for v in O], 1)
    grads["ray directions"] = np.stack([np.asarray(dr.grad(v)) for v in D], 1)
    return res, grads


def run_torch(model_cfg: ModelConfig, weights: dict, o, d, cot: dict, seed: int):
    """The torch twin, as :func:`run_drjit`, its parameters named as Dr.Jit names them."""
    model = build_torch_model(model_cfg, o.shape[1], bound_of(model_cfg))
    model.load_numpy(weights)
    O, D = torch.tensor(o, requires_grad=True), torch.tensor(d, requires_grad=True)
    outs = model.render(O, D, 1.0, 7.0, seed, training=True)
    res, loss = {}, 0
    for name, c in cot.items():
        out = outs[name]
        res[f"{name} colour"], res[f"{name} depth"] = out.rgb.detach().numpy(), out.depth.detach().numpy()
        res[f"{name} opacity"] = out.opacity.detach().numpy()
        loss = loss + sum((v * torch.from_numpy(c[k])).sum() for k, v in
                          (("rgb", out.rgb), ("depth", out.depth), ("opacity", out.opacity)))
    pts, dirs = _probe(o.shape[1])
    with torch.no_grad():
        s, c = model.fields[model.final_field()].query(torch.from_numpy(pts), torch.from_numpy(dirs))
        res["field sigma"], res["field rgb"] = s.numpy(), c.numpy()
    loss.backward()
    grads = {".".join(TORCH_NAMES.get(p, p) for p in k.replace("fields.", "", 1).split(".")): v.grad.numpy()
             for k, v in model.named_parameters()}
    grads["ray origins"], grads["ray directions"] = O.grad.numpy(), D.grad.numpy()
    return res, grads


def finite_differences(field: str, dim: int, seed: int = 0, scene: str = "object", field_args: dict | None = None
                       ) -> float:
    """Worst relative error of the custom-op gradient of a tiny case against central differences (fp32,
    eps 1e-2); every colour counts (``w_min = 0``), so no step moves a sample across the colour threshold;
    ``field_args`` replace some of :data:`FIELD_ARGS`."""
    space = RenderConfig(scene=scene, frame=FRAMES[scene]).space
    args = {**FIELD_ARGS[field], **(field_args or {}), "dim": dim, "bound": FRAMES[scene].get("bound", 1.5)}
    if field == "vanilla":
        args.update(width=8, depth=2, pos_L=2, dir_L=2, density_activation="softplus", mode="coopvec")
    if field == "hashgrid":
        args.update(mode="coopvec")
    f = make_field(field, **args)
    rng = np.random.default_rng(seed)
    w = noisy(f.to_numpy(f.init_params(seed)), rng)
    o, d = make_rays(dim, 3, seed + 1)
    cot = rng.normal(size=(3, 5)).astype(np.float32)

    def loss_of(arrays, grad=False):
        p = f.from_numpy(arrays)
        if grad:
            dr.enable_grad(p)
        out = volume_render(f, p, [Float(c) for c in o.T], [Float(c) for c in d.T], 1.0, 7.0,
                            Stratified(8, UInt32(3), jitter=True, knee=space.knee), (0.1, 0.2, 0.3), w_min=0.0,
                            space=space)
        loss = sum(dr.sum(v * Float(cot[:, k])) for k, v in enumerate(out.rgb + [out.depth, out.opacity]))
        if grad:
            dr.backward(loss)
            return f.to_numpy({k: dr.grad(v) for k, v in p.items()})
        return float(loss[0])

    analytic, worst, eps = loss_of(w, grad=True), 0.0, 1e-2
    for name in [k for k in analytic if k.rsplit(".", 1)[0] in KINK_FREE[field] or k in KINK_FREE[field]]:
        g = analytic[name]
        for flat in np.argsort(-np.abs(g).ravel())[:3]:     # the largest gradients (a grid has untouched vertices)
            idx = np.unravel_index(flat, g.shape)
            up, dn = {k: v.copy() for k, v in w.items()}, {k: v.copy() for k, v in w.items()}
            up[name][idx] += eps
            dn[name][idx] -= eps
            fd, a = (loss_of(up) - loss_of(dn)) / (2 * eps), float(g[idx])
            worst = max(worst, abs(fd - a) / max(abs(a), abs(fd), 0.1 * float(np.abs(g).max()), 1e-6))
    return worst


def check_parity(field: str = "vanilla", dim: int = 2, rays: int = 64, samples: int = 32, fine: int = 16,
                 width: int = 16, seed: int = 0, scene: str = "object", field_args: dict | None = None) -> Parity:
    """Every path of ``field`` (``dim`` D; the MLP ``width`` wide) and the torch twin on the same weights, ``rays``
    rays of ``samples`` coarse and ``fine`` fine samples (0: no fine pass) and cotangents, drawn from ``seed``, in
    the space of ``scene`` (:data:`FRAMES`; 3D); ``field_args`` replace some of :data:`FIELD_ARGS`."""
    args = {**FIELD_ARGS[field], **(field_args or {}), **({"width": width} if field == "vanilla" else {})}
    mc = ModelConfig(field, args,
                     RenderConfig(n_coarse=samples, n_fine=fine, background=(0.2, 0.3, 0.4), scene=scene,
                                  frame=FRAMES[scene]))
    model = build_model(mc, dim, bound_of(mc))
    weights = noisy(model.to_numpy(model.init_params(seed)), np.random.default_rng(seed))
    o, d = make_rays(dim, rays, seed)
    rng = np.random.default_rng(seed + 1)
    cot = {g: {"rgb": rng.normal(size=(rays, 3)).astype(np.float32),
               "depth": rng.normal(size=rays).astype(np.float32) * 0.1,
               "opacity": rng.normal(size=rays).astype(np.float32)}
           for g in (["coarse", "fine"] if fine else ["coarse"])}
    runs = {label: run_drjit(mc, weights, o, d, cot, mode, method, 7) for label, mode, method in PATHS[field]
            if mode != "native" or library() is not None}           # the native MLP needs a C compiler
    runs["torch"] = run_torch(mc, weights, o, d, cot, 7)
    ref_vals, ref_grads = runs["torch"][0], runs["drjit plain AD"][1]
    values = {k: [float(np.abs(r[0][k] - v).max()) for r in runs.values()] for k, v in ref_vals.items()}
    grads = {k: [float(np.abs(r[1][k].ravel() - v.ravel()).max()) / (float(np.abs(v).max()) + 1e-12)
                 for r in runs.values()] for k, v in ref_grads.items()}
    return Parity(list(runs), values, grads, finite_differences(field, dim, seed, scene, field_args))
