"""Cooperative vectors against tensor-mode matrix products, per MLP width.

A full Dr.Jit training step of the vanilla field (depth 4, L 8/4, 64 samples, 1024
rays) with ``mode='coopvec'`` (the field fused into the replayed march) and
``mode='tensor'`` (GEMMs on all samples, gathered by the same integral). CoopVec's
weight gradient issues one atomic add per weight per SIMD packet on LLVM, so it loses
as the width grows; ``mitnerf.fields.mlp.COOPVEC_MAX_WIDTH`` records the crossover.

    python benchmarks/coopvec_vs_tensor.py

Last line: ``coopvec faster up to width <w> (COOPVEC_MAX_WIDTH = <v>)``.
"""

from __future__ import annotations

import drjit as dr

from _common import alternate, backend, bunny
from mitnerf.fields.mlp import COOPVEC_MAX_WIDTH
from mitnerf.render.pipeline import RenderConfig
from mitnerf.train.config import ModelConfig


def main() -> None:
    dr.set_thread_count(2)
    ds = bunny()
    faster_up_to, still_faster = 0, True
    print(f"{'width':>6} {'coopvec ms':>11} {'tensor ms':>10} {'ratio c/t':>10}")
    for width in (8, 16, 24, 32, 64, 128):
        bes = {mode: backend("drjit", ModelConfig("vanilla", dict(width=width, depth=4, pos_L=8, dir_L=4, mode=mode),
                                                  RenderConfig(n_coarse=64)), ds)
               for mode in ("coopvec", "tensor")}
        t = alternate(bes, rounds=7 if width < 64 else 3)
        ratio = t["coopvec"] / t["tensor"]
        still_faster &= ratio < 1.0
        if still_faster:
            faster_up_to = width
        print(f"{width:>6} {1e3 * t['coopvec']:>11.1f} {1e3 * t['tensor']:>10.1f} {ratio:>10.2f}", flush=True)
    print(f"coopvec faster up to width {faster_up_to} (COOPVEC_MAX_WIDTH = {COOPVEC_MAX_WIDTH})")


if __name__ == "__main__":
    main()
