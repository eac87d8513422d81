"""How sharp a highlight the fields learn: the default recipes on scenes rendered at several roughnesses.

The rough materials' highlight narrows as their GGX roughness (``--roughness``, Mitsuba's ``alpha``) falls:
``bunny_glossy`` is 0.25 (``looks.ROUGHNESS``). Each roughness is a dataset of the fit table's protocol (2D: the
bunny, 50 noisy views of 100 px; 3D: the vase, 25 views of 100 x 100), fitted by ``grid`` and ``hashlinear``'s
recipes, each row's kernels compiled before its timed run (as in ``fit_table.py``). Every row: test PSNR, SSIM,
IoU (2D) or Chamfer distance (3D).

Beside the 2D rows, a reference that has the *exact* geometry: every training pixel's centre ray is intersected with
the true outline, and the colour there is fitted by least squares as harmonics of the view angle (against the wall's
normal) up to a degree, per point of the outline (bins of arc length, linear between them, kept smooth along it). Its
degree and smoothness are chosen by 5-fold cross-validation over the training views (4 validation views choose too
noisily); it is scored on the test views with the pixels whose centre ray misses counted exact. It is not a bound
(the fields also learn what falls inside a pixel's footprint, and pass it where highlights are broad); it shows how
much of a field's gap to a goal exact geometry alone would close.

The ``long`` part trains the 2D grid recipe for 10 s and for ``--long-budget`` seconds at roughness ``--long`` (each
keeping its best validation checkpoint where that is ahead by ``keep_best_margin``): the longer run's test PSNR must
not fall below the shorter one's.

The ``preset`` part says which roughness is like the renders of issue 14's report, by the one figure it gives for a
recipe we can rerun: the first wave's grid preset (:data:`PRESET`: no view dependence, no losses, coarse to fine
129 -> 513, learning rate 0.05) reached 27.8 dB on their first glossy dataset in 10 s. It trains that preset at
each 2D roughness, and the diffuse bunny beside them (the report measured 33.2 dB there).

Records ``glossy/2d``, ``glossy/3d``, ``glossy/longer`` and ``glossy/preset`` in ``results.json`` (``--parts``
chooses which); the 2D and 3D entries keep the recorded rows of roughnesses not rerun.

    python benchmarks/glossy_sweep.py [--roughness 0.05 0.12 0.2 0.25 0.3 0.5] [--roughness-3d 0.12 0.2 0.25 0.3]
                                      [--long 0.3] [--long-budget 300] [--parts 2d long 3d preset]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from mitnerf.results import load_results, record_result
from mitnerf.scenes.polygon import Polygon
from mitnerf.train.metrics import psnr
from mitnerf.train.recipes import recipe_for

if __package__:                        # imported as benchmarks.glossy_sweep (the tests)
    from .fit_table import dataset, joined, longer, row
else:                                  # run as python benchmarks/glossy_sweep.py
    from fit_table import dataset, joined, longer, row   # (fit_table imports _common: the Mitsuba variant)

FAMILIES = ("grid", "hashlinear")
DEGREES = (0, 1, 2, 4, 8, 12, 16)
SMOOTHNESS = (0.3, 1.0, 3.0, 10.0)
FOLDS = 5
BINS = 256
PRESET = dict(resolution=513, initial_resolution=129, upsample_at=(150, 400), tv_weight=1e-4, view_dependent=False,
              tv_color_weight=0.0, lr=0.05, lr_final=0.005, distortion_weight=0.0, opacity_weight=0.0,
              free_space_weight=0.0, solid_weight=0.0, keep_best=False)
"""The first wave's 2D grid recipe, as issue 14's report ran it, on top of today's ``grid-2d``."""


def outline_hits(ds, split: str, polygon: Polygon) -> dict:
    """The pixel-centre rays of ``split`` on the true outline: hit mask ``[P]``, arc fraction, view angle and view
    index of the hits ``[h]``, target colours ``[P, 3]`` (display space over the background)."""
    o, d = ds[split].cameras.rays()
    view = np.repeat(np.arange(o.shape[0]), o.shape[1] * o.shape[2])
    o, d = o.reshape(-1, 2), d.reshape(-1, 2)
    dist, arc, n = polygon.wall_hits(o, d)
    hit = np.isfinite(dist)
    v = -d[hit]                                           # towards the camera
    n = n[hit]
    angle = np.arctan2(n[:, 0] * v[:, 1] - n[:, 1] * v[:, 0], (n * v).sum(1))
    return {"hit": hit, "arc": arc[hit], "angle": angle, "view": view[hit],
            "target": ds[split].target(ds.background).reshape(-1, 3)}


def design(h: dict, degree: int) -> sp.csr_matrix:
    """``[h, BINS * (2 degree + 1)]``: hat functions of the arc fraction (periodic) times the view-angle harmonics."""
    u = h["arc"] * BINS
    i0 = np.floor(u).astype(int) % BINS
    w = u - np.floor(u)
    a = h["angle"]
    harm = np.stack([np.ones_like(a), *[f(k * a) for k in range(1, degree + 1) for f in (np.cos, np.sin)]], 1)
    nh = harm.shape[1]
    cols = np.concatenate([i0[:, None] * nh + np.arange(nh), ((i0 + 1) % BINS)[:, None] * nh + np.arange(nh)], 1)
    vals = np.concatenate([(1 - w)[:, None] * harm, w[:, None] * harm], 1)
    rows = np.repeat(np.arange(len(a)), 2 * nh)
    return sp.csr_matrix((vals.ravel(), (rows, cols.ravel())), shape=(len(a), BINS * nh))


def predict(h: dict, coef: np.ndarray, degree: int) -> np.ndarray:
    """The split's images ``[P, 3]``: the fit where the centre ray hits, the target where it misses."""
    out = h["target"].copy()
    out[h["hit"]] = design(h, degree) @ coef
    return out


def smoothness(degree: int) -> sp.csr_matrix:
    """The squared differences of neighbouring bins' coefficients (periodic), as a quadratic form."""
    step = sp.eye(BINS) - sp.eye(BINS, k=1) - sp.eye(BINS, k=1 - BINS)
    return sp.kron(step.T @ step, sp.eye(2 * degree + 1)).tocsr()


def solve(X: sp.csr_matrix, y: np.ndarray, R: sp.csr_matrix, lam: float) -> np.ndarray:
    """Least squares ``X coef = y [h, 3]`` plus ``lam**2`` times the form ``R``."""
    return spsolve((X.T @ X + lam ** 2 * R + 1e-6 * sp.eye(X.shape[1])).tocsc(), X.T @ y)


def outline_harmonics(ds) -> dict:
    """Fit and score the exact-geometry appearance reference (module docstring)."""
    polygon = Polygon.from_points(ds.meta["polygon"])
    train, test = outline_hits(ds, "train", polygon), outline_hits(ds, "test", polygon)
    y = train["target"][train["hit"]]
    fold = train["view"] % FOLDS
    scores = {}
    for degree in DEGREES:
        X, R = design(train, degree), smoothness(degree)
        for lam in SMOOTHNESS:
            scores[degree, lam] = sum(float(np.sum((np.clip(X[fold == k] @ solve(X[fold != k], y[fold != k], R, lam),
                                                            0, 1) - y[fold == k]) ** 2)) for k in range(FOLDS))
    degree, lam = min(scores, key=scores.get)
    coef = solve(design(train, degree), y, smoothness(degree), lam)
    return {"psnr": psnr(predict(test, coef, degree), test["target"]), "degree": degree, "smoothness": lam}


def merged(key: str, values: dict, command: str) -> tuple[dict, str]:
    """``values`` (by roughness) over the rows recorded under ``key`` for other roughnesses; the commands of both."""
    old = load_results().get(key, {})
    kept = {r: v for r, v in old.get("values", {}).items() if r not in values}
    rows = dict(sorted({**kept, **values}.items(), key=lambda kv: float(kv[0])))
    return rows, joined(old["command"], command) if kept else command


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--roughness", type=float, nargs="+", default=[0.05, 0.12, 0.2, 0.25, 0.3, 0.5])
    p.add_argument("--roughness-3d", type=float, nargs="+", default=[0.12, 0.2, 0.25, 0.3])
    p.add_argument("--long", type=float, default=0.3, help="roughness of the long 2D run")
    p.add_argument("--long-budget", type=float, default=300.0)
    p.add_argument("--parts", nargs="+", choices=("2d", "long", "3d", "preset"),
                   default=["2d", "long", "3d", "preset"],
                   help="what to measure (each records its own entry)")
    args = p.parse_args(argv)
    command = " ".join(["python benchmarks/glossy_sweep.py", *(sys.argv[1:] if argv is None else argv)])

    results2d = {}
    for r in args.roughness if "2d" in args.parts else ():
        ds = dataset(f"bunny_glossy_r{r:g}", 2)
        ref = outline_harmonics(ds)
        rows = {fam: row(ds, recipe_for(fam, 2), fam) for fam in FAMILIES}
        results2d[f"{r:g}"] = {"outline_harmonics": ref, **rows}
        print(f"roughness {r:g}: " + ", ".join(f"{f} {x['psnr']:.2f} dB IoU {x['geometry']:.3f}" for f, x in
                                                 rows.items())
              + f"; outline harmonics {ref['psnr']:.2f} dB (degree {ref['degree']})", flush=True)
    if results2d:
        rows2d, command2d = merged("glossy/2d", results2d, command)
        record_result("glossy/2d", rows2d, "2D bunny, 10 s, test PSNR by roughness: " + "; ".join(
            f"{r} grid {v['grid']['psnr']:.2f}, hashlinear {v['hashlinear']['psnr']:.2f}, exact-outline harmonics "
            f"{v['outline_harmonics']['psnr']:.2f} dB" for r, v in rows2d.items()), command2d)

    if "long" in args.parts:
        ds = dataset(f"bunny_glossy_r{args.long:g}", 2)
        done = results2d.get(f"{args.long:g}", {}).get("grid")          # the 2D part's 10 s row, when it ran
        recipe = recipe_for("grid", 2)
        short, long = longer(ds, recipe, recipe.train.time_budget, args.long_budget, done)
        change = long["psnr"] - short["psnr"]
        print(f"roughness {args.long:g}: 10 s {short['psnr']:.2f} dB, {args.long_budget:g} s {long['psnr']:.2f} dB "
              f"({change:+.2f})", flush=True)
        record_result("glossy/longer", {"roughness": args.long, "short": short, "long": long},
                      f"2D bunny at roughness {args.long:g}, grid recipe: test PSNR 10 s {short['psnr']:.2f} dB, "
                      f"{args.long_budget:g} s {long['psnr']:.2f} dB ({change:+.2f} dB)", command)

    if "3d" in args.parts:
        results3d = {}
        for r in args.roughness_3d:
            ds = dataset(f"vase_glossy_r{r:g}", 3)
            results3d[f"{r:g}"] = {fam: row(ds, recipe_for(fam, 3), fam) for fam in FAMILIES}
            print(f"roughness {r:g}: " + ", ".join(f"{f} {x['psnr']:.2f} dB Chamfer {x['geometry']:.4f}"
                                                     for f, x in results3d[f"{r:g}"].items()), flush=True)
        results3d, command3d = merged("glossy/3d", results3d, command)
        record_result("glossy/3d", results3d, "3D vase, 60 s, test PSNR / Chamfer by roughness: " + "; ".join(
            f"{r} " + ", ".join(f"{f} {x['psnr']:.2f} dB / {x['geometry']:.4f}" for f, x in v.items())
            for r, v in results3d.items()), command3d)

    if "preset" in args.parts:
        preset = {}
        for scene in ["bunny", *(f"bunny_glossy_r{r:g}" for r in args.roughness)]:
            x = row(dataset(scene, 2), recipe_for("grid", 2).override(**PRESET, progress=False), "first-wave preset")
            preset[scene] = x
            print(f"{scene}: first-wave preset {x['psnr']:.2f} dB", flush=True)
        record_result("glossy/preset", preset, "2D, the first wave's grid preset, 10 s (issue 14's report: 27.8 dB on "
                      "its glossy data, 33.2 on our bunny): " + "; ".join(f"{k} {v['psnr']:.2f}"
                                                                          for k, v in preset.items()), command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
