"""Ground-truth generation speed (warm kernel cache, 2 threads).

Targets: 2D, 300 views of 100 px in <= 2 s; 3D, 100 views of 100x100 with exact
depth in <= 10 s. Each is timed after one warm-up render of the same configuration.

    python benchmarks/dataset_speed.py

Last line: ``2d <t> s (ratio <t/2>); 3d <t> s (ratio <t/10>)``.
"""

from __future__ import annotations

import time

import drjit as dr

import mitnerf
from mitnerf.data.generate import make_dataset
from mitnerf.data.rig import RigConfig, noise_preset
from mitnerf.scenes.registry import get_scene

mitnerf.set_variant()


def timed(scene, rig) -> float:
    make_dataset(scene, rig, progress=False)          # warm-up: kernels compiled and cached
    t0 = time.perf_counter()
    make_dataset(scene, rig, progress=False)
    return time.perf_counter() - t0


def main() -> None:
    dr.set_thread_count(2)
    t2 = timed(get_scene("bunny"), RigConfig(dim=2, n_train=300, n_val=0, n_test=0, **noise_preset(1)))
    print(f"2D bunny, 300 views x 100 px, colour + depth + mask: {t2:.2f} s (target 2 s)")
    times3 = {}
    for name in ("vase", "nut"):
        times3[name] = timed(get_scene(name), RigConfig(dim=3, n_train=100, n_val=0, n_test=0, **noise_preset(1)))
        print(f"3D {name}, 100 views x 100x100, colour + depth + mask: {times3[name]:.2f} s (target 10 s)")
    t3 = max(times3.values())
    print(f"2d {t2:.2f} s (ratio {t2 / 2:.2f}); 3d {t3:.2f} s (ratio {t3 / 10:.2f})")


if __name__ == "__main__":
    main()
