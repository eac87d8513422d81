"""Cross-check the ground truth: render the same views with Mitsuba's ``scalar_rgb`` and ``llvm_ad_rgb``
variants and compare colour, depth and mask (:func:`mitnerf.scenes.gt_render.compare_variants`).

The variants draw different sample sequences, so colour is compared as PSNR between two converged
renders; depth and mask come from the same pixel-centre rays and must agree to float precision.

    python examples/check_renderers.py [--scenes bunny vase] [--views 6] [--resolution 24]

Prints one line per scene and a final pass/fail line; exits 1 on failure.
"""

from __future__ import annotations

import argparse
import sys

from mitnerf.data.rig import RigConfig, make_rig
from mitnerf.scenes.gt_render import compare_variants
from mitnerf.scenes.registry import get_scene


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="+", default=["bunny", "vase"])
    p.add_argument("--views", type=int, default=6)
    p.add_argument("--resolution", type=int, default=24)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--min-psnr", type=float, default=40.0, help="colour PSNR between the variants")
    p.add_argument("--depth-tol", type=float, default=1e-4, help="max abs depth difference on hits")
    args = p.parse_args(argv)

    ok = True
    for name in args.scenes:
        scene = get_scene(name)
        dim = 2 if scene.kind == "2d" else 3
        cams = make_rig(RigConfig(dim=dim, n_train=args.views, n_val=0, n_test=0, resolution=args.resolution *
                                  (4 if dim == 2 else 1), radius_std=0.1, angle_std=2, seed=1)).train
        c = compare_variants(scene.load, cams.mitsuba_frames(), cams.fov, cams.height, cams.width, *cams.rays(),
                             args.spp)
        passed = c["psnr"] >= args.min_psnr and c["depth_error"] <= args.depth_tol and c["masks_equal"]
        ok &= passed
        masks, (ta, tb) = "equal" if c["masks_equal"] else "DIFFER", c["seconds"]
        print(f"{name:>15}: colour PSNR {c['psnr']:6.1f} dB (max |diff| {c['max_diff']:.2e}), depth max |diff| "
              f"{c['depth_error']:.2e}, masks {masks}; scalar {ta:.2f} s, llvm {tb:.2f} s  "
              + ("ok" if passed else "FAIL"))
    print("check_renderers: PASS" if ok else "check_renderers: FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
