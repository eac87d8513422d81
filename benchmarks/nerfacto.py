"""The peer row of the lego benchmark (``benchmarks/lego.py``): nerfstudio's nerfacto trained on this CPU for the
same wall time, on the same 400 x 400 lego, scored over white by mitnerf's own metrics against the same targets.

nerfacto runs in a fresh process of a separate interpreter that holds nerfstudio (``--python``; the project does
not depend on nerfstudio), through ``benchmarks/_nerfacto_driver.py``, whose docstring lists what differs from
``ns-train nerfacto blender-data`` and why (the CPU settings are recorded as ``settings``). It trains for
``--time-budget`` seconds with ``--threads`` threads, then renders ``--test-views`` test views evenly spread over
the 200 (nerfacto renders a 400 x 400 view in minutes on this CPU, so not all 200), whose PSNR (over all their
pixels) and mean SSIM against the RGBA test images composited over white, as mitnerf's Blender reader reads them,
are recorded in ``results.json`` as ``lego/nerfacto/<budget>``, with those of mitnerf's own 600 s fit on the same
views (``ours``) where ``benchmarks/lego.py --parts 600`` has left it in ``out/lego/600``. Where the interpreter,
nerfstudio or the data is absent, one line says so and nothing runs. The interpreter is made so (torch's CPU
build, nerfstudio without its GPU, viewer and export dependencies):

    python3.11 -m venv NSVENV
    NSVENV/bin/pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu
    NSVENV/bin/pip install nerfstudio==1.1.5 --no-deps
    NSVENV/bin/pip install tyro jaxtyping rich numpy pillow imageio opencv-python-headless==4.10.0.84 \
        torchmetrics nerfacc==0.5.2 matplotlib appdirs requests rawpy pyquaternion msgspec websockets \
        protobuf absl-py
    NSVENV/bin/pip install --no-deps viser==0.2.7 tensorboard

    python benchmarks/nerfacto.py [--time-budget 600] [--test-views 4] [--python NSVENV/bin/python] [--rescore]

``--rescore`` trains nothing: it scores the renders the last run left in ``out/lego/nerfacto-<budget>`` and
mitnerf's fit again (after ``benchmarks/lego.py --parts 600`` has refitted it), with the same views.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

if __package__:                        # imported as benchmarks.nerfacto (the tests)
    from ._cli import ROOT, run
    from .lego import DATA
else:                                  # run as python benchmarks/nerfacto.py
    from _cli import ROOT, run
    from lego import DATA

OURS = "600"
"""The budget of mitnerf's lego run scored beside nerfacto on the same views (``benchmarks/lego.py --parts 600``)."""
PYTHON = Path("/work/wt/nsvenv/bin/python")
"""The interpreter holding nerfstudio (made as the module docstring says)."""
DRIVER = Path(__file__).with_name("_nerfacto_driver.py")
SETTINGS = ("nerfstudio 1.1.5 nerfacto as ns-train builds it for blender-data (4096 rays a batch, SO3xR3 camera "
            "optimiser, nerfacto's optimisers), on the CPU: machine.device-type cpu, "
            "pipeline.model.implementation torch (no tiny-cuda-nn), mixed precision off (float32), "
            "VanillaDataManager (single process, images cached before the clock starts), blender-data "
            "alpha-color white, pipeline.model.background-color white, viewer and writers off, LPIPS stubbed "
            "(no torchvision), eval_num_rays_per_chunk 4096, seed 42")
"""What the recorded run set (``settings`` in ``results.json``); ``_nerfacto_driver.py`` says why."""


def missing(python: Path | None, data: Path) -> str | None:
    """Why the benchmark cannot run (one line), or None; ``python`` None: no interpreter needed (a rescore)."""
    if not (data / "transforms_test.json").is_file():
        return f"no Blender lego at {data} (see ../shared/data/README.md)"
    if python is None:
        return None
    if not python.is_file():
        return f"no interpreter at {python} (make it as benchmarks/nerfacto.py's docstring says, or give --python)"
    if subprocess.run([str(python), "-c", "import nerfstudio"], capture_output=True).returncode:
        return f"{python} cannot import nerfstudio (install it as benchmarks/nerfacto.py's docstring says)"
    return None


def score(dataset, out: Path, views) -> dict:
    """PSNR and SSIM of ``out/renders.npy`` against ``views`` of the test split over white, and their seconds."""
    import numpy as np

    from mitnerf.train.metrics import psnr, ssim

    target = dataset["test"].target((1.0, 1.0, 1.0), views=np.asarray(views))
    rgb = np.load(out / "renders.npy")
    t0 = time.perf_counter()
    values = {"psnr": psnr(rgb, target), "ssim": ssim(rgb, target)}
    return {**values, "score_s": time.perf_counter() - t0, "size": f"{target.shape[2]} x {target.shape[1]}"}


def ours(dataset, views: int) -> dict | None:
    """PSNR and SSIM of mitnerf's own lego fit (``benchmarks/lego.py``'s ``out/lego/<budget>``, when it is there) on
    the same test views, or None."""
    run_dir = ROOT / "out" / "lego" / OURS
    if not (run_dir / "manifest.json").is_file():
        return None
    from mitnerf.train.checkpoint import load_checkpoint
    from mitnerf.train.evaluate import evaluate

    run, _ = load_checkpoint(run_dir)
    rec = evaluate(run.backend, dataset, "test", geometry_metrics=False, views=views)
    return {"psnr": rec.psnr, "ssim": rec.ssim, "run": f"out/lego/{OURS}"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--time-budget", type=int, default=600, help="seconds of training")
    p.add_argument("--test-views", type=int, default=4, help="test views rendered, evenly spread over the split")
    p.add_argument("--threads", type=int, default=2, help="CPU threads of the nerfacto process")
    p.add_argument("--python", type=Path, default=PYTHON, help="an interpreter holding nerfstudio")
    p.add_argument("--data", type=Path, default=DATA, help="the lego_400 folder")
    p.add_argument("--rescore", action="store_true",
                   help="train nothing: score the renders an earlier run left and mitnerf's fit (after a new "
                        "benchmarks/lego.py --parts 600) again")
    args = p.parse_args(argv)
    out = ROOT / "out" / "lego" / f"nerfacto-{args.time_budget}"
    why = missing(None if args.rescore else args.python, args.data)
    if why:
        print(f"nerfacto: skipped, {why}")
        return 0
    if args.rescore and not (out / "run.json").is_file():
        print(f"nerfacto: no earlier run in {out} to rescore; run without --rescore", file=sys.stderr)
        return 2
    from mitnerf.results import record_result
    from mitnerf.train.evaluate import test_views

    n = len(json.loads((args.data / "transforms_test.json").read_text())["frames"])
    views = test_views(n, args.test_views).tolist()
    wall = None
    if not args.rescore:
        cmd = [args.python, DRIVER, "--data", args.data, "--time-budget", args.time_budget, "--threads", args.threads,
               "--views", ",".join(map(str, views)), "--out", out]
        _, wall = run(cmd)
    ran = json.loads((out / "run.json").read_text())
    from mitnerf.data.formats import load_dataset

    dataset = load_dataset(args.data)                  # read once: the targets, and our fit's evaluation
    s = score(dataset, out, views)
    v = {"psnr": s["psnr"], "ssim": s["ssim"], "steps": ran["steps"], "train_s": ran["train_s"], "views": len(views),
         "size": s["size"], "eval_s": ran["render_s"] + s["score_s"], "recipe": "nerfacto",
         **({"wall_s": wall} if wall is not None else {})}
    summary = (f"nerfacto: test PSNR {v['psnr']:.2f} dB, SSIM {v['ssim']:.3f} on {len(views)} of {n} views of "
               f"{v['size']} over white; {v['steps']} steps in {v['train_s']:.0f} s, threads {args.threads}; "
               f"evaluation {v['eval_s']:.0f} s" + (" (renders of an earlier run, rescored)" if args.rescore else ""))
    mine = ours(dataset, args.test_views)
    if mine is not None:
        v["ours"] = mine
        summary += f"; mitnerf ({mine['run']}) on the same views {mine['psnr']:.2f} dB, SSIM {mine['ssim']:.3f}"
    print(f"lego/nerfacto/{args.time_budget}: {summary}")
    command = " ".join(["python benchmarks/nerfacto.py", *(argv if argv is not None else sys.argv[1:])]).strip()
    record_result(f"lego/nerfacto/{args.time_budget}", v, summary, command, recipe="nerfacto", threads=args.threads,
                  settings=f"{SETTINGS}; torch {ran['torch']}, nerfstudio {ran['nerfstudio']}, views {views}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
