"""Peak memory of the volume integral: the custom operation against plain AD.

256 samples per ray through the vanilla field (width 16, depth 4, L 8/4, CoopVec, so
that the custom operation can run the field inside its march). One measurement is one
forward + backward pass of ``volume_render`` (colour, depth and opacity, random
cotangents) on rays already in memory, in its own process: a 64-ray pass compiles the
kernels at a tiny peak, then the cost is the process's peak resident memory minus its
resident memory just before the measured pass. Measuring at 4096 and 32768 rays and
taking the slope removes fixed overheads; the table reports it for 4096 rays.

Dr.Jit is lazy, so plain AD stores only what its block prefix sums force to memory
(a few floats per sample; the MLP's activations are recomputed inside the backward
kernel); the custom integral's loop state is a few floats per ray.

    python benchmarks/memory.py

Last line: ``custom <a> MB autodiff <b> MB ratio <a/b>``.
"""

from __future__ import annotations

from _cli import child

CHILD = r"""
import json, resource, sys
import numpy as np, drjit as dr
import mitnerf
from drjit.auto.ad import Float, UInt32
from mitnerf.fields.mlp import NeRFConfig, NeRFField
from mitnerf.render.samplers import Stratified
from mitnerf.render.volume import volume_render
method, n = sys.argv[1], int(sys.argv[2])
dr.set_thread_count(2)
field = NeRFField(NeRFConfig(dim=2, width=16, depth=4, pos_L=8, dir_L=4, mode="coopvec", density_bias=0.5))
params = field.init_params(0)

def rays(k, seed):
    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 2 * np.pi, k)
    o = [Float((4 * np.cos(a)).astype(np.float32)), Float((4 * np.sin(a)).astype(np.float32))]
    d = [Float((-np.cos(a)).astype(np.float32)), Float((-np.sin(a)).astype(np.float32))]
    cot = [Float(rng.normal(size=k).astype(np.float32)) for _ in range(5)]
    dr.eval(o, d, cot)
    return o, d, cot

def once(k, seed):
    o, d, cot = rays(k, seed)
    p = {key: Float(v) for key, v in params.items()}
    dr.enable_grad(p)
    out = volume_render(field, p, o, d, 1.0, 7.0, Stratified(256, UInt32(seed)), (0.0, 0.0, 0.0), method=method)
    vals = out.rgb + [out.depth, out.opacity]
    dr.backward(sum(dr.sum(v * c) for v, c in zip(vals, cot)))
    g = [dr.grad(v) for v in p.values()]
    dr.eval(g)
    dr.sync_thread()

once(64, 1)                      # compile at a tiny peak
def rss_kb():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS"):
            return int(line.split()[1])
o, d, cot = rays(n, 2)           # the inputs exist before the measurement
del o, d, cot
dr.flush_malloc_cache()
before = rss_kb()
once(n, 3)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"delta_mb": (peak - before) / 1024}))
"""


def measure(method: str, rays: int) -> float:
    return child(CHILD, method, rays)["delta_mb"]


def per_4096_rays(method: str) -> float:
    lo, hi = measure(method, 4096), measure(method, 32768)
    return (hi - lo) / (32768 - 4096) * 4096


def main() -> None:
    rows = {}
    for method in ("replay", "autodiff"):
        rows[method] = per_4096_rays(method)
        print(f"{method:>8} integral: {rows[method]:7.2f} MB per 4096 rays x 256 samples "
              f"({rows[method] * 2**20 / 4096 / 4:.0f} floats per ray)", flush=True)
    a, b = rows["replay"], rows["autodiff"]
    print(f"custom {a:.2f} MB autodiff {b:.2f} MB ratio {a / b:.3f}")


if __name__ == "__main__":
    main()
