"""Cross-backend check: the same weights, rays and random cotangents through

  (a) the Dr.Jit custom volume integral (replayed adjoint), with a CoopVec field
      (fused into the march) and with a tensor-mode field (gathered samples),
  (b) Dr.Jit plain automatic differentiation (flat samples, block prefix sums),
  (c) the PyTorch reference,

comparing field outputs, colour, depth, opacity (coarse and fine passes), the gradient
of every weight and of the ray origins and directions; then finite differences on a
tiny case. Prints the max abs and relative error per quantity and a final pass/fail
line; exits 1 on failure.

fp32 tolerances, against (c) for values and (b) for gradients:
  values       max |err| <= 1e-5 (colours and opacities are O(1); depths O(5): 5e-5)
  gradients    max |err| / max |reference| <= 5e-3. Typically ~1e-5 (2^L-frequency
               encodings amplify the fp32 rounding of positions). The slack is for ReLU
               kinks: when a pre-activation lies within rounding of zero, Dr.Jit's FMAs
               and torch's GEMM accumulation can put it on different sides, and that
               sample's gradient changes by a finite step (seen: 1.6e-3 on a 16-ray,
               width-8 case, where an fp64 reference sided with one backend). Bugs give
               errors of 1e-2 and more.
  finite diff. central differences in fp32 (eps 1e-2, the 3 largest-gradient entries of
               every parameter after the last ReLU, 3 rays x 8 samples): |fd - grad| <= 2e-2 x
               max(|grad|, |fd|, 10 % of the largest gradient of that tensor)

Fields (``--field``): the vanilla MLP (CoopVec and tensor modes), the dense grid (always
fused into the march), the hash grid (CoopVec and tensor networks), the linearly decoded hash
grid (fused into the march, as the dense grid). Weights are the
field's initialisation, with N(0, 0.3) noise added to grid values and hash tables (they
start constant or near zero). Network weights keep their initialisation: noise there
puts ReLU pre-activations within the finite-difference step of their kinks.

    python examples/check_backends.py [--field vanilla|grid|hashgrid|hashlinear] [--dim 2|3] [--rays 64]
                                      [--samples 32] [--fine 16]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import mitnerf  # noqa: F401

TOL_VALUE, TOL_DEPTH, TOL_GRAD, TOL_FD = 1e-5, 5e-5, 5e-3, 2e-2


def make_rays(dim: int, n: int, seed: int):
    rng = np.random.default_rng(seed)
    if dim == 2:
        a = rng.uniform(0, 2 * np.pi, n)
        o = np.stack([4 * np.cos(a), 4 * np.sin(a)], 1)
    else:
        v = rng.normal(size=(n, 3))
        o = 4 * v / np.linalg.norm(v, axis=1, keepdims=True)
    d = -o / 4 + rng.normal(0, 0.15, o.shape)
    return o.astype(np.float32), (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


FIELD_ARGS = {   # small fields, each with view dependence
    "vanilla": dict(width=16, depth=4, pos_L=6, dir_L=3, density_bias=0.5),
    "grid": dict(resolution=17, view_dependent=True, tv_weight=0.0, density_init=0.5),
    "hashgrid": dict(n_levels=4, log2_hashmap_size=10, base_resolution=4, max_resolution=32, hidden=8,
                     geo_features=3, view_dependent=True, dir_L=2, density_activation="softplus", density_bias=0.5),
    "hashlinear": dict(resolutions=(5, 9, 17), dense_levels=1, log2_hashmap_size=6, view_levels=2, initial_levels=3,
                       tv_weight=0.0, tv_color_weight=0.0, density_init=0.5),
}
# (label, network mode or None, integral) per field
VARIANTS = {
    "vanilla": [("custom op, coopvec field", "coopvec", "replay"), ("custom op, tensor field", "tensor", "replay"),
                ("custom op, native MLP", "native", "replay"), ("drjit plain AD", "tensor", "autodiff")],
    "grid": [("custom op, fused grid", None, "replay"), ("drjit plain AD", None, "autodiff")],
    "hashlinear": [("custom op, fused levels", None, "replay"), ("drjit plain AD", None, "autodiff")],
    "hashgrid": [("custom op, coopvec nets", "coopvec", "replay"), ("custom op, tensor nets", "tensor", "replay"),
                 ("drjit plain AD", "tensor", "autodiff")],
}


GRID_ARRAYS = ("density", "color", "table")
# Parameters no ReLU follows: moving them by the finite-difference step moves no kink, so
# central differences in fp32 are exact to rounding. (Earlier layers are checked against
# plain AD and torch above.)
KINK_FREE = {"vanilla": ("sigma", "color.1"), "grid": ("density", "color"), "hashlinear": ("density", "color"),
             "hashgrid": ("table", "sigma_net.1", "color_net.1")}


def noisy(arrays: dict, rng) -> dict:
    """N(0, 0.3) noise on grid values and hash tables; network weights unchanged."""
    return {k: (v + rng.normal(0, 0.3, v.shape)).astype(np.float32) if k.split(".")[-1] in GRID_ARRAYS else v
            for k, v in arrays.items()}


def random_weights(model_cfg, dim: int, seed: int) -> dict:
    from mitnerf.train.backend_drjit import build_model

    model = build_model(model_cfg, dim, 1.5)
    return noisy(model.to_numpy(model.init_params(seed)), np.random.default_rng(seed))


def run_drjit(model_cfg, weights, o, d, cot, mode, method, seed):
    import dataclasses

    import drjit as dr
    from drjit.auto.ad import Float, UInt32

    from mitnerf.render.pipeline import split_params
    from mitnerf.train.backend_drjit import build_model

    args = dict(model_cfg.field_args) if mode is None else {**model_cfg.field_args, "mode": mode}
    cfg = dataclasses.replace(model_cfg, field_args=args, render=dataclasses.replace(model_cfg.render, method=method))
    model = build_model(cfg, o.shape[1], 1.5)
    params = model.from_numpy(weights)
    dr.enable_grad(params)
    O = [Float(c) for c in o.T]
    D = [Float(c) for c in d.T]
    dr.enable_grad(O, D)
    outs = model.render(params, O, D, 1.0, 7.0, UInt32(seed), training=True, input_grads=True)
    loss = 0
    res = {}
    for name in ("coarse", "fine"):
        out = outs[name]
        if out is None:
            continue
        rgb = np.stack([np.asarray(c) for c in out.rgb], 1)
        res[f"{name} colour"], res[f"{name} depth"] = rgb, np.asarray(out.depth)
        res[f"{name} opacity"] = np.asarray(out.opacity)
        c = cot[name]
        loss = loss + sum(dr.sum(out.rgb[k] * Float(c["rgb"][:, k])) for k in range(3))
        loss = loss + dr.sum(out.depth * Float(c["depth"])) + dr.sum(out.opacity * Float(c["opacity"]))
    pts = np.random.default_rng(5).uniform(-1.4, 1.4, (256, o.shape[1])).astype(np.float32)
    dirs = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    g = model.final_field()
    with dr.suspend_grad():
        s, c = model.fields[g].query(split_params(params, g), [Float(v) for v in pts.T], [Float(v) for v in dirs.T])
        res["field sigma"], res["field rgb"] = np.asarray(s), np.stack([np.asarray(v) for v in c], 1)
    dr.backward(loss)
    grads = model.to_numpy({k: dr.grad(v) for k, v in params.items()})
    grads["ray origins"] = np.stack([np.asarray(dr.grad(v)) for v in O], 1)
    grads["ray directions"] = np.stack([np.asarray(dr.grad(v)) for v in D], 1)
    return res, grads


def run_torch(model_cfg, weights, o, d, cot, seed):
    import torch

    from mitnerf.train.backend_torch import build_torch_model

    model = build_torch_model(model_cfg, o.shape[1], 1.5)
    model.load_numpy(weights)
    O, D = torch.tensor(o, requires_grad=True), torch.tensor(d, requires_grad=True)
    outs = model.render(O, D, 1.0, 7.0, seed, training=True)
    res, loss = {}, 0
    for name in ("coarse", "fine"):
        out = outs[name]
        if out is None:
            continue
        res[f"{name} colour"], res[f"{name} depth"] = out.rgb.detach().numpy(), out.depth.detach().numpy()
        res[f"{name} opacity"] = out.opacity.detach().numpy()
        c = cot[name]
        loss = loss + (out.rgb * torch.from_numpy(c["rgb"])).sum() + (out.depth * torch.from_numpy(c["depth"])).sum()
        loss = loss + (out.opacity * torch.from_numpy(c["opacity"])).sum()
    pts = np.random.default_rng(5).uniform(-1.4, 1.4, (256, o.shape[1])).astype(np.float32)
    dirs = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    with torch.no_grad():
        s, c = model.fields[model.final_field()].query(torch.from_numpy(pts), torch.from_numpy(dirs))
        res["field sigma"], res["field rgb"] = s.numpy(), c.numpy()
    loss.backward()
    grads = {k: v.grad.numpy() for k, v in model.named_parameters()}
    names = {"density_grid": "density", "color_grid": "color", "density_table": "density", "color_table": "color"}
    grads = {".".join(names.get(p, p) for p in k.replace("fields.", "", 1).split(".")): v for k, v in grads.items()}
    grads["ray origins"], grads["ray directions"] = O.grad.numpy(), D.grad.numpy()
    return res, grads


def finite_differences(field: str, dim: int, seed: int = 0, verbose: bool = False) -> float:
    """Custom-op gradient of a tiny case against central differences (fp32, eps 1e-2); every colour counts
    (``w_min = 0``), so no step of the differences moves a sample across the colour threshold."""
    import drjit as dr
    from drjit.auto.ad import Float, UInt32

    from mitnerf.fields import make_field
    from mitnerf.render.samplers import Stratified
    from mitnerf.render.volume import volume_render

    args = {**FIELD_ARGS[field], "dim": dim, "bound": 1.5}
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
                            Stratified(8, UInt32(3), jitter=True), (0.1, 0.2, 0.3), w_min=0.0)
        loss = sum(dr.sum(v * Float(cot[:, k])) for k, v in enumerate(out.rgb + [out.depth, out.opacity]))
        if grad:
            dr.backward(loss)
            return f.to_numpy({k: dr.grad(v) for k, v in p.items()})
        return float(loss[0])

    analytic = loss_of(w, grad=True)
    worst = 0.0
    for name in [k for k in analytic if k.rsplit(".", 1)[0] in KINK_FREE[field] or k in KINK_FREE[field]]:
        g = analytic[name]
        # the entries with the largest gradients (a grid has many untouched vertices)
        for flat in np.argsort(-np.abs(g).ravel())[:3]:
            idx = np.unravel_index(flat, g.shape)
            eps = 1e-2
            up, dn = {k: v.copy() for k, v in w.items()}, {k: v.copy() for k, v in w.items()}
            up[name][idx] += eps
            dn[name][idx] -= eps
            fd = (loss_of(up) - loss_of(dn)) / (2 * eps)
            a = float(g[idx])
            floor = 0.1 * float(np.abs(g).max())
            err = abs(fd - a) / max(abs(a), abs(fd), floor, 1e-6)
            if verbose and err > 1e-2:
                print(f"  fd {name}{list(idx)}: analytic {a:.5g}, central difference {fd:.5g}")
            worst = max(worst, err)
    return worst


def main(argv=None) -> int:
    from mitnerf.fields.native import library
    from mitnerf.render.pipeline import RenderConfig
    from mitnerf.train.config import ModelConfig

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--field", choices=list(FIELD_ARGS), default="vanilla")
    p.add_argument("--dim", type=int, choices=[2, 3], default=2)
    p.add_argument("--rays", type=int, default=64)
    p.add_argument("--samples", type=int, default=32)
    p.add_argument("--fine", type=int, default=16)
    p.add_argument("--width", type=int, default=16)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    field_args = dict(FIELD_ARGS[args.field])
    if args.field == "vanilla":
        field_args["width"] = args.width
    mc = ModelConfig(args.field, field_args, RenderConfig(n_coarse=args.samples, n_fine=args.fine,
                                                          background=(0.2, 0.3, 0.4)))
    weights = random_weights(mc, args.dim, args.seed)
    groups = ["coarse", "fine"] if args.fine else ["coarse"]
    o, d = make_rays(args.dim, args.rays, args.seed)
    rng = np.random.default_rng(args.seed + 1)
    cot = {g: {"rgb": rng.normal(size=(args.rays, 3)).astype(np.float32),
               "depth": rng.normal(size=args.rays).astype(np.float32) * 0.1,
               "opacity": rng.normal(size=args.rays).astype(np.float32)} for g in groups}

    runs = {label: run_drjit(mc, weights, o, d, cot, mode, method, 7) for label, mode, method in VARIANTS[args.field]
            if mode != "native" or library() is not None}           # the native MLP needs a C compiler
    runs["torch"] = run_torch(mc, weights, o, d, cot, 7)
    ok = True
    ref_vals, ref_grads = runs["torch"][0], runs["drjit plain AD"][1]
    print(f"field {args.field}, {args.dim}D")
    print(f"{'quantity':<22}" + "".join(f"{k:>28}" for k in runs))
    for key in ref_vals:
        tol = TOL_DEPTH if "depth" in key else TOL_VALUE
        errs = [float(np.abs(r[0][key] - ref_vals[key]).max()) for r in runs.values()]
        ok &= all(e <= tol for e in errs)
        print(f"{key:<22}" + "".join(f"{e:>19.2e} abs     " for e in errs))
    for key in ref_grads:
        scale = float(np.abs(ref_grads[key]).max()) + 1e-12
        errs = [float(np.abs(r[1][key].ravel() - ref_grads[key].ravel()).max()) / scale for r in runs.values()]
        ok &= all(e <= TOL_GRAD for e in errs)
        print(f"d/d {key:<18}" + "".join(f"{e:>19.2e} rel     " for e in errs))
    fd = finite_differences(args.field, args.dim, args.seed)
    ok &= fd <= TOL_FD
    print(f"finite differences (custom op vs central, fp32): worst relative error {fd:.2e} (tolerance {TOL_FD:g})")
    print("check_backends: PASS" if ok else "check_backends: FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
