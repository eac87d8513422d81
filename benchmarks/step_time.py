"""Training-step time of the vanilla NeRF on Dr.Jit and PyTorch, in one run.

Two configurations, both with L = 8 / 5, 64 coarse + 64 fine samples (a separate fine
network, as NeRF) and 1024 rays per step on the 2D bunny:

* NeRF2D's 6 x 128 MLP (GEMM-bound: torch is near its peak, so the limit is the FLOP count);
* a 4 x 32 MLP (launch- and memory-bound).

Steps of the two backends alternate (same machine state); the median of each is
reported, and the MLP part alone (forward + backward of every layer on the step's
samples) is timed to give its FLOP/s beside the machine's fp32 GEMM peak. At width 32
both backends also train for the same number of steps from the same weights, on the
same batches, and report their validation PSNR.

    python benchmarks/step_time.py [--rounds 7] [--psnr-steps 400]

Last line: ``w128 drjit <a> ms torch <b> ms ratio <a/b>; w32 drjit <c> ms torch <d> ms ratio <c/d>``.
"""

from __future__ import annotations

import argparse
import time

import drjit as dr
import numpy as np
import torch

from _common import alternate, backend, bunny, gemm_peak
from mitnerf.fields.mlp import NeRFConfig, layer_shapes
from mitnerf.render.pipeline import RenderConfig
from mitnerf.train.config import ModelConfig


def config(width: int, depth: int) -> ModelConfig:
    return ModelConfig("vanilla", dict(width=width, depth=depth, pos_L=8, dir_L=5),
                       RenderConfig(n_coarse=64, n_fine=64))


def mlp_flops(cfg: NeRFConfig, n: int) -> float:
    """FLOPs of forward + backward of every linear layer on ``n`` samples (no input gradient)."""
    total = 0.0
    for name, o, i in layer_shapes(cfg):
        total += n * o * i * (4 if name == "trunk.0" else 6)
    return total


def time_mlp_drjit(be, n: int, dim: int, reps: int = 3) -> float:
    from drjit.auto.ad import Float

    from mitnerf.render.pipeline import split_params

    field = be.model.fields["fine"]
    params = split_params(be.params, "fine")
    rng = np.random.default_rng(0)
    x = [Float(rng.uniform(-1, 1, n).astype(np.float32)) for _ in range(dim)]
    d = [Float(v) for v in rng.normal(size=(dim, n)).astype(np.float32)]
    ts = []
    for _ in range(reps + 1):
        p = {k: dr.detach(v) for k, v in params.items()}
        dr.enable_grad(p)
        dr.sync_thread()
        t0 = time.perf_counter()
        s, c = field.query(p, x, d)
        dr.backward(dr.sum(s) + dr.sum(c[0] + c[1] + c[2]))
        dr.eval([dr.grad(v) for v in p.values()])
        dr.sync_thread()
        ts.append(time.perf_counter() - t0)
    return min(ts[1:])


def time_mlp_torch(be, n: int, dim: int, reps: int = 3) -> float:
    field = be.model.fields["fine"]
    rng = np.random.default_rng(0)
    x = torch.from_numpy(rng.uniform(-1, 1, (n, dim)).astype(np.float32))
    d = torch.from_numpy(rng.normal(size=(n, dim)).astype(np.float32))
    ts = []
    for _ in range(reps + 1):
        field.zero_grad()
        t0 = time.perf_counter()
        s, c = field.query(x, d)
        (s.sum() + c.sum()).backward()
        ts.append(time.perf_counter() - t0)
    return min(ts[1:])


def equal_steps_psnr(ds, mc, steps: int) -> dict:
    from mitnerf.train.config import TrainConfig
    from mitnerf.train.trainer import evaluate, fit

    out = {}
    for name in ("drjit", "torch"):
        run = fit(ds, mc, TrainConfig(iters=steps, val_every=0, progress=False, lr=5e-3, lr_final=5e-4), name)
        out[name] = evaluate(run, ds, "test")["psnr"]
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--psnr-steps", type=int, default=400)
    args = p.parse_args()
    dr.set_thread_count(2)
    torch.set_num_threads(2)
    ds = bunny()
    peak = gemm_peak()
    print(f"machine fp32 GEMM peak (2048^3, best of torch and Dr.Jit): {peak:.0f} GFLOP/s")
    result = {}
    for width, depth in ((128, 6), (32, 4)):
        mc = config(width, depth)
        bes = {name: backend(name, mc, ds) for name in ("drjit", "torch")}
        t = alternate(bes, rounds=args.rounds if width == 32 else max(3, args.rounds // 2))
        n_samples = 1024 * (64 + 128)      # coarse net on 64, fine net on 64 + 64 per ray
        fcfg = NeRFConfig(dim=2, width=width, depth=depth, pos_L=8, dir_L=5)
        flops = mlp_flops(fcfg, n_samples)
        mlp = {"drjit": time_mlp_drjit(bes["drjit"], n_samples, 2), "torch": time_mlp_torch(bes["torch"], n_samples, 2)}
        for name in ("drjit", "torch"):
            print(f"w{width} x{depth} {name:>5}: step {1e3 * t[name]:7.1f} ms; MLP part {1e3 * mlp[name]:7.1f} ms = "
                  f"{flops / mlp[name] / 1e9:5.0f} GFLOP/s ({100 * flops / mlp[name] / 1e9 / peak:3.0f} % of peak); "
                  f"whole step {flops / t[name] / 1e9:5.0f} GFLOP/s of MLP work", flush=True)
        result[width] = t
    psnr = equal_steps_psnr(ds, config(32, 4), args.psnr_steps)
    print(f"w32 after {args.psnr_steps} equal steps (same weights, batches, jitter): test PSNR "
          f"drjit {psnr['drjit']:.2f} dB, torch {psnr['torch']:.2f} dB")
    a, b = 1e3 * result[128]["drjit"], 1e3 * result[128]["torch"]
    c, d = 1e3 * result[32]["drjit"], 1e3 * result[32]["torch"]
    print(f"w128 drjit {a:.0f} ms torch {b:.0f} ms ratio {a / b:.2f}; w32 drjit {c:.0f} ms torch {d:.0f} ms ratio {c / d:.2f}")


if __name__ == "__main__":
    main()
