"""The standard benchmark at its own size: the NeRF Blender-synthetic lego (400 x 400; 100 train, 100 val and 200
test views), fitted by the plain command line as a user runs it, each part in a fresh process:

    mitnerf fit --data <lego_400> --time-budget 600     (part 600)
    mitnerf fit --data <lego_400> --time-budget 3600    (part 3600)

every other setting the defaults (the white background, all 200 test views). Each part records in
``results.json`` (``lego/600``, ``lego/3600``) the test PSNR and SSIM over the 200 views, the steps, the
evaluation's time and the process's peak memory, read from the run's ``metrics.json``, with the command and the
machine. Part ``800`` (``lego800/upsampled``) fits the same views upsampled twice (nearest, into a temporary
folder) for :data:`BUDGET_800` seconds: the original 800 x 800 lego's pixel count, so its peak memory and the
evaluation of its 200 test views at that size, though not its accuracy (the PSNR of blocky views is no figure).
Part ``resolution`` (``lego_resolution/3600``) scores the field part ``3600`` wrote on the test views at their size and
box-filtered to 200 x 200: what halving the pixels' size costs this field, read as the drop to expect from 400 x 400 to
the held-back 800 x 800; and on its 100 training views, the gap between views it saw and views it did not. Part
``quadrature`` (``lego_quadrature/3600``) renders that field's 200 test views with each of :data:`OVERSAMPLES` times its
training samples a ray (``RenderConfig.render_oversample``; the recipe's: 4), in one process: the PSNR and the seconds
of each, the evidence for the recipe's choice. Part ``auto`` (``lego/auto/120``) runs ``mitnerf fit --data <lego_400>
--auto --time-budget 120``: the search's probes, what it chose, the chosen recipe's test figures and the whole command's
wall time. The default recipe takes the lego's density on a lattice twice as fine as its colour's
(``Sizing.density_refine``); part ``single`` (``lego/single/600``) runs part ``600``'s command with ``--set
density_refine=1``, one lattice for both in the same floats (more colour vertices): what that choice is measured
against. Part ``grey`` (``lego/grey/3600``) runs part ``3600``'s command with ``--set view_color=grey``: the same
lattice with one set of view harmonics shared by the three channels (``GridSettings.view_color``), half the colour's
floats, so more steps in the hour and less memory. The default draws most of a batch's rays where the field's last
errors were (``TrainConfig.mining``, ``Sizing.mining``); part ``uniform`` (``lego/uniform/600``) runs part ``600``'s
command with ``--set mining=0``: twice the rays, drawn uniformly, as before mining; part ``uniform-hour``
(``lego/uniform/3600``) the same beside part ``3600``. The lego's training rays show white where its images are empty;
part ``random`` (``lego/random/600``) runs part ``600``'s command with ``--set background=random``: a uniform colour
per training ray where the image's alpha lets it through (as instant-ngp trains), so the field cannot paint white
into empty space; evaluated over white all the same; part ``random-hour`` (``lego/random/3600``) the same beside part
``3600``. Part ``samples128`` (``lego/samples128/3600``) runs part
``3600``'s command with ``--set n_coarse=128``: twice the samples a ray, so fewer steps in the hour; part
``800-samples128`` (``lego800/samples128``) measures its memory and evaluation time at 800 x 800, beside part ``800``'s.
Part ``fine`` (``lego/fine/3600``) runs part ``3600``'s command on a finer lattice (a 175^3 cube's floats rather than
161^3), with four times the training samples in rendering set (the recipe's own value); part ``800-fine``
(``lego800/fine``) measures its memory and evaluation time at 800 x 800. Run each beside its default in one session: the
pair is measured on one machine.
``benchmarks/report.py`` shows them in RESULTS.md beside the published figures (:data:`ANCHORS`) and the peer on
this CPU (``benchmarks/nerfacto.py``). Where the data is absent, one line says so and nothing runs.

    python benchmarks/lego.py [--parts 600 800 3600 resolution quadrature auto single grey uniform uniform-hour
                               random random-hour samples128 800-samples128 fine 800-fine]
                              [--data ../shared/data/nerf_synthetic/lego_400]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

if __package__:                        # imported as benchmarks.lego (the tests)
    from ._cli import ROOT, mitnerf, said
else:                                  # run as python benchmarks/lego.py
    from _cli import ROOT, mitnerf, said

DATA = ROOT.parent / "shared" / "data" / "nerf_synthetic" / "lego_400"
PARTS = ("600", "800", "3600", "resolution", "quadrature", "auto", "single", "grey", "uniform", "uniform-hour",
         "random", "random-hour", "samples128", "800-samples128", "fine", "800-fine")
BUDGET_800 = "150"
"""Seconds of training at 800 x 800: past the last coarse-to-fine step, where the grid and its memory are whole."""
RUN_3600 = ROOT / "out" / "lego" / "3600"
"""Where part ``3600`` writes its fit, which parts ``resolution`` and ``quadrature`` score."""
OVERSAMPLES = (1, 2, 4, 8)
"""``render_oversample`` values part ``quadrature`` renders the hour's field with."""
BUDGET_AUTO = "120"
"""Seconds of each of ``fit --auto``'s probes and of the chosen recipe's training (part ``auto``)."""
VARIANTS = {"single": ("single", "600", ("density_refine=1",)), "grey": ("grey", "3600", ("view_color=grey",)),
            "uniform": ("uniform", "600", ("mining=0",)), "uniform-hour": ("uniform", "3600", ("mining=0",)),
            "random": ("random", "600", ("background=random",)),
            "random-hour": ("random", "3600", ("background=random",)),
            "samples128": ("samples128", "3600", ("n_coarse=128",)),
            "fine": ("fine", "3600", ("resolution=213", "density_refine=2", "render_oversample=4"))}
"""Parts that run a budget's plain command with ``--set`` settings: ``(row, seconds, settings)``, recorded as
``lego/<row>/<seconds>``; ``single``: one lattice for density and colour, against part ``600``'s default; ``grey``: grey
view harmonics, against part ``3600``'s; ``uniform`` and ``uniform-hour``: every batch drawn uniformly (twice the rays),
against parts ``600``'s and ``3600``'s mined batches; ``random`` and ``random-hour``: a random background behind each
training ray, against parts ``600``'s and ``3600``'s white; ``samples128``: twice the samples a ray, against part
``3600``'s; ``fine``: the lattice that a 175^3 cube's floats give (213 vertices on the lego's fullest axis, against
the default's 197 from 161^3) and four times the training samples in rendering (the recipe's own value), against part
``3600``'s."""
UPSAMPLED = {"800": ("lego800/upsampled", ()),
             "800-samples128": ("lego800/samples128", VARIANTS["samples128"][2]),
             "800-fine": ("lego800/fine", ("resolution=209", *VARIANTS["fine"][2][1:]))}
"""Parts on the views upsampled to 800 x 800: ``(key, settings)``; ``800-samples128``: part ``samples128``'s setting;
``800-fine``: part ``fine``'s, its lattice as a 175^3 cube's floats size it on these views' box (209 a side)."""
ANCHORS = [
    ("NeRF", "32.54", "about a day", "V100"),
    ("Plenoxels", "~34.1", "11-15 min", "GPU"),
    ("DVGO", "~34.6", "11-15 min", "GPU"),
    ("instant-ngp", "29.6 / 33.4 / 36.4", "~5 s / ~15 s / 5 min", "RTX 3090"),
    ("nerfacc (occupancy grid NeRF)", "35.67", "288 s", "TITAN RTX"),
]
"""Published test PSNR on lego, 800 x 800, white background, the 200 test views: (method, dB, training time, GPU)."""


def upsampled(data: Path, folder: Path) -> Path:
    """The Blender folder ``data`` with every view twice as large (each pixel repeated 2 x 2) in ``folder``."""
    import imageio.v3 as iio
    import numpy as np
    from tqdm.auto import tqdm

    for f in data.glob("transforms_*.json"):
        (folder / f.name).write_text(f.read_text())
    for png in tqdm(sorted(data.glob("*/*.png")), desc="upsample", unit="view", delay=1):
        (folder / png.parent.name).mkdir(exist_ok=True)
        iio.imwrite(folder / png.parent.name / png.name, np.repeat(np.repeat(iio.imread(png), 2, 0), 2, 1))
    return folder


def set_flags(settings: tuple) -> list:
    """The command line's ``--set`` flags of ``settings`` (``key=value`` each)."""
    return [f for s in settings for f in ("--set", s)]


def fit(data: Path, budget: str, part: str | None = None, *flags: str) -> dict:
    """``mitnerf fit`` with the time budget and nothing else (but ``flags``), in a fresh process: its metrics and its
    own lines."""
    out = ROOT / "out" / "lego" / (part or budget)
    args = ["fit", "--data", str(data), *flags, "--time-budget", budget, "--out", str(out)]
    lines, wall = mitnerf(*args)
    metrics = json.loads((out / "metrics.json").read_text())
    size = "{} x {}".format(*json.loads((out / "manifest.json").read_text())["dataset"]["size"])
    return {"metrics": metrics, "size": size, "wall": wall, "first": said(lines, "recipe "), "last": lines[-1],
            "auto": [ln.removeprefix("auto: ") for ln in lines if ln.startswith("auto: ")],
            "command": " ".join(["python -m mitnerf", *args]).replace(str(ROOT) + "/", "").replace(
                str(ROOT.parent) + "/", "../")}


def scored_at_sizes(run: Path, data: Path) -> dict:
    """The field in ``run`` on every test view of ``data`` at their size and box-filtered twice smaller, and on every
    training view at its size: ``{1: (PSNR, SSIM, size), 2: (...), "train": (...)}``."""
    from mitnerf.data.formats import load_dataset
    from mitnerf.train.checkpoint import load_checkpoint
    from mitnerf.train.evaluate import evaluate

    backend = load_checkpoint(run)[0].backend
    out = {}
    for k in (1, 2):
        ds = load_dataset(data, k)
        for key, split in [(k, "test")] + ([("train", "train")] if k == 1 else []):
            rec = evaluate(backend, ds, split, geometry_metrics=False)
            out[key] = (rec.psnr, rec.ssim, "{} x {}".format(ds[split].cameras.width, ds[split].cameras.height))
    return out


def scored_with_oversamples(run: Path, data: Path) -> dict:
    """The field in ``run`` on every test view of ``data``, rendered with each of :data:`OVERSAMPLES`:
    ``{k: {"psnr", "ssim", "render_s"}}``."""
    from mitnerf.data.formats import load_dataset
    from mitnerf.train.checkpoint import load_checkpoint
    from mitnerf.train.evaluate import evaluate

    backend, ds = load_checkpoint(run)[0].backend, load_dataset(data)
    out = {}
    for k in OVERSAMPLES:
        backend.model_cfg.render.render_oversample = k
        rec = evaluate(backend, ds, "test", geometry_metrics=False)
        out[k] = {"psnr": rec.psnr, "ssim": rec.ssim, "render_s": rec.render_time * rec.views}
    return out


def resolution_figures(run: Path, data: Path) -> tuple[dict, str]:
    """Part ``resolution``'s values and line: :func:`scored_at_sizes` of the hour's field."""
    got = scored_at_sizes(run, data)
    (p1, s1, size1), (p2, s2, size2), (pt, st, _) = got[1], got[2], got["train"]
    v = {"run": "out/lego/3600", "psnr": p1, "ssim": s1, "size": size1, "psnr_half": p2, "ssim_half": s2,
         "size_half": size2, "gain_db": p2 - p1, "psnr_train": pt, "ssim_train": st, "gap_db": pt - p1}
    return v, (f"the lego/3600 field on the 200 test views: {p1:.2f} dB, SSIM {s1:.3f} at {size1}; "
               f"{p2:.2f} dB, SSIM {s2:.3f} box-filtered to {size2} ({p2 - p1:+.2f} dB): halving the pixels' "
               f"size costs this lattice about {p2 - p1:.1f} dB, the drop to expect from {size1} to 800 x 800; "
               f"on its own training views {pt:.2f} dB, SSIM {st:.3f} ({pt - p1:+.2f} dB over the test views: "
               "what it fits and does not carry to new views)")


def quadrature_figures(run: Path, data: Path) -> tuple[dict, str]:
    """Part ``quadrature``'s values and line: :func:`scored_with_oversamples` of the hour's field."""
    got = scored_with_oversamples(run, data)
    return {"run": "out/lego/3600", **{f"x{k}": g for k, g in got.items()}}, (
        "the lego/3600 field's 200 test views rendered with " + "; ".join(
            f"{k}x its training samples: {g['psnr']:.3f} dB in {g['render_s']:.1f} s" for k, g in got.items()))


def values_of(run: dict) -> dict:
    m = run["metrics"]
    return {"size": run["size"], "psnr": m["psnr"], "ssim": m["ssim"], "train_s": m["train_time"],
            "steps": m["steps"], "eval_s": m["eval_time"], "render_s": m["render_time"] * m["views"],
            "peak_gib": m["peak_memory"], "views": m["views"], "background": m["background"], "recipe": m["recipe"],
            "wall_s": run["wall"]}


def summary(v: dict) -> str:
    return (f"test PSNR {v['psnr']:.2f} dB, SSIM {v['ssim']:.3f} on {v['views']} views of {v['size']} over "
            f"{v['background']}; {v['steps']} steps in {v['train_s']:.0f} s; evaluation {v['eval_s']:.0f} s "
            f"(rendering {v['render_s']:.0f} s); "
            f"peak memory {v['peak_gib']:.2f} GiB; recipe {v['recipe']}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS),
                   help="which parts to run: budgets in seconds, 800 (memory and evaluation time at 800 x 800), auto "
                        "(fit --auto), resolution (the 3600 s field on views twice smaller and on its training "
                        "views), quadrature (the 3600 s field rendered with 1, 2, 4 and 8 times its samples), "
                        "single (part 600 with one lattice for density and colour), grey (part 3600 with "
                        "grey view harmonics), uniform and uniform-hour (parts 600 and 3600 with uniform draws), "
                        "random and random-hour (parts 600 and 3600 with a random background in training), "
                        "samples128 and 800-samples128 (parts 3600 and 800 with 128 samples a ray), fine and "
                        "800-fine (parts 3600 and 800 with a finer lattice and more samples in rendering)")
    p.add_argument("--data", type=Path, default=DATA, help="the lego_400 folder")
    args = p.parse_args(argv)
    if not (args.data / "transforms_train.json").is_file():
        print(f"lego: skipped, no Blender lego at {args.data} (see ../shared/data/README.md)")
        return 0
    from mitnerf.results import record_result
    from mitnerf.train.config import TrainConfig

    for budget in args.parts:
        if budget in UPSAMPLED:
            key, settings = UPSAMPLED[budget]
            flags = set_flags(settings)
            (ROOT / "out").mkdir(exist_ok=True)
            with tempfile.TemporaryDirectory(dir=ROOT / "out") as tmp:
                run = fit(upsampled(args.data, Path(tmp)), BUDGET_800, budget, *flags)
                command = run["command"].replace(str(Path(tmp).relative_to(ROOT)), "<lego_400 upsampled>")
            v = values_of(run)
            line = (f"{v['size']} views (the 400 x 400 ones upsampled, nearest)" + "".join(f" {f}" for f in flags)
                    + f": peak memory {v['peak_gib']:.2f} GiB, evaluation of {v['views']} test views "
                    f"{v['eval_s']:.0f} s (rendering "
                    f"{v['render_s']:.0f} s), after {v['train_s']:.0f} s of training ({v['steps']} steps); "
                    f"recipe {v['recipe']}")
            print(f"{key}: {line}")
            record_result(key, v, line, f"python benchmarks/lego.py --parts {budget} (runs: {command})",
                          recipe=v["recipe"], threads=TrainConfig().threads)
            continue
        if budget in ("resolution", "quadrature"):
            if not (RUN_3600 / "manifest.json").is_file():
                print(f"lego_{budget}: skipped, no fit at {RUN_3600} (run --parts 3600 first)")
                continue
            v, line = (resolution_figures if budget == "resolution" else quadrature_figures)(RUN_3600, args.data)
            print(f"lego_{budget}/3600: {line}")
            record_result(f"lego_{budget}/3600", v, line, f"python benchmarks/lego.py --parts {budget}",
                          recipe=json.loads((RUN_3600 / "metrics.json").read_text())["recipe"],
                          threads=TrainConfig().threads)
            continue
        if budget == "auto":
            run = fit(args.data, BUDGET_AUTO, "auto", "--auto")
            v = dict(values_of(run), search=run["auto"])
            line = (f"fit --auto with probes of {BUDGET_AUTO} s: {summary(v)}; "
                    f"{sum(ln.endswith('[size]') for ln in v['search'])} sizes probed, {v['wall_s'] / 60:.1f} min in "
                    "all (search, training, evaluation)")
            print(f"lego/auto/{BUDGET_AUTO}: {line}\n    " + "\n    ".join(v["search"]))
            record_result(f"lego/auto/{BUDGET_AUTO}", v, line, run["command"], recipe=v["recipe"],
                          threads=TrainConfig().threads)
            continue
        if budget in VARIANTS:
            row, seconds, settings = VARIANTS[budget]
            run = fit(args.data, seconds, f"{row}-{seconds}", *set_flags(settings))
            v = values_of(run)
            print(f"lego/{row}/{seconds}: {summary(v)}\n    {run['first']}")
            record_result(f"lego/{row}/{seconds}", v, summary(v), run["command"], recipe=v["recipe"],
                          threads=TrainConfig().threads)
            continue
        run = fit(args.data, budget)
        v = values_of(run)
        print(f"lego/{budget}: {summary(v)}\n    {run['first']}")
        record_result(f"lego/{budget}", v, summary(v), run["command"], recipe=v["recipe"],
                      threads=TrainConfig().threads)
    return 0


if __name__ == "__main__":
    sys.exit(main())
