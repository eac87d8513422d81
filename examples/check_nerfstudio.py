"""Hand our data to nerfstudio: export a 3D and a 2D dataset with `mitnerf dataset --format
nerfstudio`, load each with nerfstudio's own `nerfstudio-data` parser (no options), and compare
its rays, images, depths and masks with mitnerf's.

nerfstudio always re-centres and rescales the poses (``dataparser_transform``,
``dataparser_scale``); the comparison maps its rays back, ``x = R^T (x_ns / s - t)``,
``d = R^T d_ns``. Its depth is z-depth times ``depth_unit_scale_factor`` (1e-3, the value our
writer follows) times ``dataparser_scale``, which is compared with our distance along the ray
times the ray's cosine. Tolerances (fp32): rays 1e-5, images 1/255, depth 1e-4 relative.

nerfstudio is not a mitnerf dependency. Its parser runs without its GPU stack: in a virtual
environment with mitnerf (``pip install -e .``),

    pip install torch==2.13.0 && pip install nerfstudio==1.1.5 --no-deps
    pip install jaxtyping opencv-python-headless==4.10.0.84 viser==1.1.1 tensorboard
    python examples/check_nerfstudio.py [--out out/check_nerfstudio]

Prints one line per dataset and split, and ``check_nerfstudio: PASS`` or ``FAIL`` (exit 1).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from mitnerf.cli import main as cli
from mitnerf.data.formats import load_dataset
from mitnerf.results import record_result

TOL_RAY, TOL_IMAGE, TOL_DEPTH = 1e-5, 1.0 / 255 + 1e-6, 1e-4
DATASETS = {"vase": ["--scene", "vase", "--views", "6", "--val", "2", "--test", "3", "--image-size", "24"],
            "bunny": ["--scene", "bunny", "--views", "12", "--val", "3", "--test", "5", "--image-size", "64"]}


worst: dict = {}


def compare(folder: Path) -> bool:
    from nerfstudio.data.dataparsers.nerfstudio_dataparser import NerfstudioDataParserConfig
    from nerfstudio.data.utils.data_utils import get_depth_image_from_path

    ours = load_dataset(folder)
    ok = True
    for split, theirs_name in (("train", "train"), ("val", "val"), ("test", "test")):
        out = NerfstudioDataParserConfig(data=folder).setup().get_dataparser_outputs(split=theirs_name)
        T, s = out.dataparser_transform.double().numpy(), float(out.dataparser_scale)
        R, t = T[:, :3], T[:, 3]
        mine = ours[split]
        o, d = mine.cameras.rays()
        if ours.dim == 2:                                        # our 2D rays live in the z = 0 plane
            o, d = (np.concatenate([a, np.zeros(a.shape[:-1] + (1,))], -1) for a in (o, d))
        names = [Path(f).name for f in out.image_filenames]      # nerfstudio sorts frames by path
        order = sorted(range(len(names)), key=lambda i: names[i])
        err = {"origin": 0.0, "direction": 0.0, "image": 0.0, "depth": 0.0}
        factor = float(out.metadata.get("depth_unit_scale_factor", 1e-3))
        for i, k in enumerate(order):
            rb = out.cameras.generate_rays(camera_indices=i, keep_shape=True)
            o_ns = (rb.origins.double().numpy() / s - t) @ R
            d_ns = rb.directions.double().numpy() @ R
            err["origin"] = max(err["origin"], float(np.abs(o_ns - o[k]).max()))
            err["direction"] = max(err["direction"], float(np.abs(d_ns - d[k]).max()))
            img = np.asarray(iio.imread(out.image_filenames[i]), np.float32) / 255
            straight = np.where(mine.alpha[k][..., None] > 0, mine.color[k] / np.maximum(mine.alpha[k], 1e-8)[
                ..., None], 0.0)
            err["image"] = max(err["image"], float(np.abs(img[..., :3] - straight).max()))
            if mine.depth is not None:
                H, W = mine.cameras.height, mine.cameras.width
                z = get_depth_image_from_path(out.metadata["depth_filenames"][i], H, W, factor * s)[..., 0].numpy()
                cos = np.abs(rb.metadata["directions_norm"][..., 0].numpy()) ** -1.0
                hit = mine.mask[k]
                rel = np.abs(z[hit] / s / cos[hit] - mine.depth[k][hit]) / mine.depth[k][hit]
                err["depth"] = max(err["depth"], float(rel.max()) if rel.size else 0.0)
        good = (err["origin"] <= TOL_RAY and err["direction"] <= TOL_RAY and err["image"] <= TOL_IMAGE
                and err["depth"] <= TOL_DEPTH)
        ok &= good
        worst[folder.name] = max(worst.get(folder.name, 0.0), err["origin"], err["direction"])
        print(f"{folder.name:>6} {split:>5}: {len(order)} views, max |origin| {err['origin']:.1e}, |direction| "
              f"{err['direction']:.1e}, |image| {err['image']:.1e}, depth rel. {err['depth']:.1e}  "
              f"{'ok' if good else 'FAIL'}")
    return ok


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="out/check_nerfstudio")
    args = p.parse_args(argv)
    warnings.filterwarnings("ignore")          # torch's indexing deprecation warnings inside nerfstudio
    ok = True
    for name, flags in DATASETS.items():
        folder = Path(args.out) / name
        if cli(["dataset", *flags, "--format", "nerfstudio", "--out", str(folder)]):
            return 1
        ok &= compare(folder)
    print("check_nerfstudio: PASS" if ok else "check_nerfstudio: FAIL")
    if ok:
        record_result("check/nerfstudio", worst, "nerfstudio 1.1.5's nerfstudio-data parser loads our 3D and 2D "
                      "exports with no options; rays within " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()),
                      "python examples/check_nerfstudio.py")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
