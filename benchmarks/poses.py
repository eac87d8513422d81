"""``mitnerf poses`` against known cameras (issue 33's goals), each run through the plain command line:

* ``poses/fern``: LLFF's fern, ``images_4`` (1008 x 756, 20 photos): every image registered, camera centres within
  1 % of the scene's extent of LLFF's own after a similarity (:func:`mitnerf.data.align.pose_errors`), in under a
  minute. The extent is the spread of LLFF's camera centres (their largest distance; the stricter yardstick for
  a forward-facing capture) and, beside it, the deepest of LLFF's depth bounds.
* ``poses/renders``: our own renders exported without poses (``brick_table``, a ring of views, PNGs over white):
  every camera within 0.5 degrees, with the default lens model (SIMPLE_RADIAL) and with SIMPLE_PINHOLE (theirs).
* ``poses/fit/fern``, ``poses/fit/renders`` (``--fit-budget S``, after a run without it): ``mitnerf fit
  --time-budget S`` on the folders that run posed and on the true poses (LLFF's folder; the renders' truth moved
  into the recovered world by the similarity of the centres, pinhole with the true focal length), each evaluated
  on its own held-out views (every 8th image: the same photographs in both): the goal is within 0.5 dB.

    python benchmarks/poses.py [--fern DIR] [--out DIR] [--no-fern] [--no-renders]
    python benchmarks/poses.py --fit-budget S [--out DIR]

Last line: ``poses: fern <k>/<n> registered, centres <e> % of the spread, <t> s; renders <d> deg`` (with
``--fit-budget``: ``poses: fit fern <gap> dB; fit renders <gap> dB``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np

if __package__:                        # imported as benchmarks.poses (the tests)
    from ._cli import ROOT, mitnerf
else:                                  # run as python benchmarks/poses.py
    from _cli import ROOT, mitnerf

FERN = ROOT.parent / "shared" / "data" / "llff" / "fern"
if not FERN.exists():
    FERN = Path("/work/shared/data/llff/fern")
RING = dict(n=40, size=400)
"""The renders: views on the ring (9 degrees apart, elevation 25, radius 3.5) and their size in pixels."""


def rel(path: Path) -> str:
    """``path`` as a command names it: relative to the repository where it lies inside."""
    path = Path(path).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def cli(*args: str, ok=(0,)) -> tuple[str, float]:
    """``python -m mitnerf ARGS`` from the repository: (its stdout, seconds); stops the benchmark on an exit status
    not in ``ok``."""
    lines, seconds = mitnerf(*args, ok=ok)
    return "\n".join(lines), seconds


def frames(data: Path) -> tuple[list[str], np.ndarray]:
    """The image names and OpenGL camera-to-world poses a ``transforms.json`` lists."""
    header = json.loads((data / "transforms.json").read_text())
    return [Path(f["file_path"]).name for f in header["frames"]], np.array([f["transform_matrix"]
                                                                             for f in header["frames"]])


def llff_poses(fern: Path, downscale: int) -> tuple[list[str], np.ndarray, float]:
    """LLFF's image names, poses (in name order) and deepest depth bound, read by mitnerf's LLFF reader."""
    from mitnerf.data.formats import load_dataset
    from mitnerf.data.formats.capture import hold_out
    from mitnerf.data.formats.capture import image_folder

    ds = load_dataset(fern, downscale=downscale)
    folder = image_folder(fern, downscale, str(fern))[0]
    names = sorted(p.name for p in folder.iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
    split = hold_out(len(names), str(fern))
    poses = np.empty((len(names), 4, 4))
    poses[split["train"]], poses[split["test"]] = ds["train"].cameras.poses, ds["test"].cameras.poses
    return names, poses, float(np.max(ds.meta["bounds"]))


def llff_errors(fern: Path, data: Path, downscale: int):
    """``(PoseErrors, spread of LLFF's camera centres, images registered)`` of the poses in ``data``."""
    from mitnerf.data.align import pose_errors

    names, truth, _ = llff_poses(fern, downscale)
    ours, poses = frames(data)
    index = [names.index(n) for n in ours]
    spread = float(np.linalg.norm(truth[:, None, :3, 3] - truth[None, :, :3, 3], axis=-1).max())
    return pose_errors(poses, truth[index]), spread, len(ours)


def psnr(stdout: str) -> tuple[float, str]:
    """The test PSNR of ``mitnerf fit``'s last line, and the run's failure (``collapsed: ...``) or ``ok``."""
    last = stdout.strip().splitlines()[-1]
    failed = re.search(r"\[([a-z]+: [^\]]*)\]", last)
    return float(re.search(r"test PSNR ([0-9.]+) dB", last).group(1)), failed.group(1) if failed else "ok"


def with_poses(data: Path, truth: np.ndarray, focal: float, out: Path) -> Path:
    """A copy of the posed folder ``data`` whose cameras are ``truth [n, 4, 4]`` (pinhole, ``focal``), moved into
    its world by the similarity that best maps their centres onto the recovered ones."""
    from mitnerf.data.align import similarity

    shutil.rmtree(out, ignore_errors=True)             # the benchmark's own earlier copy
    shutil.copytree(data, out, ignore=shutil.ignore_patterns(".mitnerf"))
    header = json.loads((out / "transforms.json").read_text())
    _, ours = frames(data)
    s, R, t = similarity(truth[:, :3, 3], ours[:, :3, 3])
    for f, P in zip(header["frames"], truth):
        M = np.eye(4)
        M[:3, :3], M[:3, 3] = R @ P[:3, :3], s * R @ P[:3, 3] + t
        f["transform_matrix"] = M.tolist()
    header.update(camera_model="PINHOLE", fl_x=focal, fl_y=focal, cx=header["w"] / 2, cy=header["h"] / 2,
                  k1=0.0, k2=0.0, p1=0.0, p2=0.0, k3=0.0)
    (out / "transforms.json").write_text(json.dumps(header, indent=1))
    return out


def fern_part(fern: Path, out: Path) -> str:
    from mitnerf.results import record_result

    data = out / "fern"
    command = f"mitnerf poses --images {rel(fern)}/images_4 --out {rel(data)}"
    load = os.getloadavg()[0]                          # other work on the machine slows COLMAP down
    _, seconds = cli("poses", "--images", fern / "images_4", "--out", data, "--overwrite")
    load = max(load, os.getloadavg()[0])
    e, spread, registered = llff_errors(fern, data, downscale=4)
    depth = llff_poses(fern, 4)[2]
    worst = float(e.position.max())
    values = {"registered": registered, "images": 20, "seconds": seconds, "load": load, "spread": spread,
              "depth": depth, "position_max": worst, "position_max_pct_spread": 100 * worst / spread,
              "position_max_pct_depth": 100 * worst / depth,
              "rotation_max_deg": float(e.rotation.max()), "rotation_mean_deg": float(e.rotation.mean()),
              "goal": {"all registered": registered == 20, "centres within 1 %": e.position.max() < 0.01 * spread,
                       "under a minute": seconds < 60}}
    summary = (f"fern images_4: {registered}/20 registered, camera centres within "
               f"{values['position_max_pct_spread']:.2f} % of LLFF's camera spread "
               f"({values['position_max_pct_depth']:.3f} % of its depth), orientations within "
               f"{values['rotation_max_deg']:.2f} deg, {seconds:.0f} s at load {load:.1f} on {os.cpu_count()} cores "
               "(goals: all, 1 %, 60 s)")
    record_result("poses/fern", values, summary, command, threads=2)
    print(summary)
    return f"fern {registered}/20 registered, centres {values['position_max_pct_spread']:.2f} % of the spread, " \
           f"{seconds:.0f} s"


def render_ring(folder: Path) -> tuple[np.ndarray, float]:
    """Write the ring of ``brick_table`` views as PNGs over white into ``folder``; their poses and focal length."""
    import mitnerf
    from mitnerf.data.cache import cached_dataset
    from mitnerf.data.color import to_uint8
    from mitnerf.data.rig import RigConfig
    from mitnerf.scenes.gt_render import RenderSettings

    mitnerf.set_variant()
    ds = cached_dataset("brick_table", RigConfig(dim=3, n_train=1, n_val=1, n_test=RING["n"],
                                                 resolution=RING["size"], seed=0), RenderSettings(spp=16))
    folder.mkdir(parents=True, exist_ok=True)
    for i, img in enumerate(ds["test"].target((1.0, 1.0, 1.0))):
        iio.imwrite(folder / f"{i:03d}.png", to_uint8(img))
    return ds["test"].cameras.poses, float(ds["test"].cameras.fx[0])


def renders_part(out: Path) -> str:
    from mitnerf.data.align import pose_errors
    from mitnerf.results import record_result

    photos = out / "ring_photos"
    truth, focal = render_ring(photos)
    values, commands = {}, []
    for model in ("SIMPLE_RADIAL", "SIMPLE_PINHOLE"):
        data = out / f"ring_{model.lower()}"
        commands.append(f"mitnerf poses --images {rel(photos)} --out {rel(data)} --camera-model {model}")
        _, seconds = cli("poses", "--images", photos, "--out", data, "--camera-model", model, "--overwrite")
        names, poses = frames(data)
        e = pose_errors(poses, truth[[int(Path(n).stem) for n in names]])
        values[model] = {"registered": len(names), "images": RING["n"], "seconds": seconds,
                         "rotation_max_deg": float(e.rotation.max()), "rotation_mean_deg": float(e.rotation.mean()),
                         "position_max_pct_radius": 100 * float(e.position.max()) / 3.5,
                         "focal_error_pct": 100 * abs(json.loads((data / "transforms.json").read_text())["fl_x"]
                                                      / focal - 1)}
    worst = max(v["rotation_max_deg"] for v in values.values())
    summary = "brick_table ring, {n} views of {size} px: ".format(**RING) + "; ".join(
        f"{m} {v['registered']}/{v['images']} registered, within {v['rotation_max_deg']:.2f} deg and "
        f"{v['position_max_pct_radius']:.2f} % of the radius, focal {v['focal_error_pct']:.2f} % off, "
        f"{v['seconds']:.0f} s" for m, v in values.items()) + " (goal: 0.5 deg)"
    record_result("poses/renders", values, summary, " && ".join(commands), threads=2)
    print(summary)
    return f"renders {worst:.2f} deg"


def fit_pair(name: str, data: Path, other: Path, budget: float) -> str:
    """Test PSNR of a fit on our poses (``data``) and on the true ones (``other``) at ``budget`` seconds each
    (``poses/fit/<name>``)."""
    from mitnerf.results import record_result

    got, status = {}, {}
    for label, folder in (("ours", data), ("true", other)):
        stdout, _ = cli("fit", "--data", folder, "--time-budget", budget, ok=(0, 1))    # 1: a collapsed run
        got[label], status[label] = psnr(stdout)
    gap = got["true"] - got["ours"]
    notes = "".join(f"; the fit on {k} poses {v}" for k, v in status.items() if v != "ok")
    summary = (f"{name}: fit on our poses {got['ours']:.2f} dB, on the true ones {got['true']:.2f} dB ({gap:+.2f} dB; "
               f"goal within 0.5) at --time-budget {budget:g}{notes}")
    record_result(f"poses/fit/{name}", {**got, "gap": gap, "budget": budget, "status": status}, summary,
                  f"python benchmarks/poses.py && mitnerf fit --data {rel(data)} --time-budget {budget:g} && mitnerf "
                  f"fit --data {rel(other)} --time-budget {budget:g}", threads=2)
    print(summary)
    return f"fit {name} {gap:+.2f} dB"


def fits_part(fern: Path, out: Path, budget: float) -> list[str]:
    """The fits on the posed folders an earlier run wrote into ``out``."""
    lines = []
    if (out / "fern" / "transforms.json").exists() and fern.is_dir():
        lines.append(fit_pair("fern", out / "fern", fern, budget))
    data = out / "ring_simple_radial"
    if (data / "transforms.json").exists():
        truth, focal = render_ring(out / "ring_photos")
        ours = frames(data)[0]
        lines.append(fit_pair("renders", data, with_poses(data, truth[[int(Path(n).stem) for n in ours]], focal,
                                                         out / "ring_true"), budget))
    if not lines:
        print(f"no posed folders in {out}: run `python benchmarks/poses.py --out {out}` first")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fern", type=Path, default=FERN, help="LLFF's fern folder (poses_bounds.npy, images_4/)")
    p.add_argument("--out", type=Path, default=ROOT / "out" / "bench_poses", help="where the posed data go")
    p.add_argument("--fit-budget", type=float, default=None,
                   help="instead, fit on the posed folders of an earlier run and on the true poses (seconds each)")
    p.add_argument("--no-fern", action="store_true")
    p.add_argument("--no-renders", action="store_true")
    a = p.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.fit_budget:
        print("poses: " + "; ".join(fits_part(a.fern, a.out, a.fit_budget)))
        return 0
    lines = []
    if not a.no_fern:
        if (a.fern / "images_4").is_dir():
            lines.append(fern_part(a.fern, a.out))
        else:
            print(f"skipped the fern: {a.fern}/images_4 is absent (real data: /work/shared/data)")
    if not a.no_renders:
        lines.append(renders_part(a.out))
    print("poses: " + "; ".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
