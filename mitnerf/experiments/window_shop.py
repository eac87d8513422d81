"""Window shopping: the ten NeRF combinations of Wu's report, row for row, then our additions.

Every combination of ``COMBINATIONS`` runs on each of ``objects``: N images are the first N photos
of one pool, or N spread over it (``Config.pick``); the NeRF is the ``vanilla-3d`` recipe with the combination's
settings and no fine pass (and FreeNeRF's frequency window where the images are few, ``Config.few_views``), every
row with the same time budget and at most ``iters`` steps. Writes ``results.csv``, ``report.md``,
``psnr_vs_views.png`` and ``thumbnails.png``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..data.cache import cached_dataset
from ..data.dataset import Dataset, Split
from ..data.formats import load_dataset
from ..data.rig import RigConfig, noise_preset
from ..errors import DataError
from ..settings import setting
from ..train.recipes import get_recipe
from ..viz.panels import image_grid, image_panel, series_figure
from .claims import _f, _ws, judged
from .report import markdown_table, train_row, write_csv, write_report

COMBINATIONS = {
    # index: (images, L, N_c, view dependence, the report's PSNR in dB)
    1: (100, 6, 64, True, 23.5), 2: (100, 10, 64, True, 23.8), 3: (100, 6, 128, True, 24.2),
    4: (25, 6, 64, True, 25.0), 5: (25, 10, 64, True, 23.8), 6: (10, 6, 64, False, 22.5),
    7: (5, 6, 64, True, 23.0), 8: (5, 6, 128, True, 15.0), 9: (5, 10, 64, True, 24.0), 10: (5, 10, 128, True, 16.0),
}
"""The report's Table 1 (combinations, all at 2000 iterations) with its Table 2 (PSNR)."""
ARCHITECTURES = {"ours": dict(width=64, depth=4, skip=2, dir_L=1), "paper": dict(width=256, depth=8, skip=4, dir_L=4)}
"""``ours``: the ``vanilla-3d`` recipe's MLP with one direction frequency; ``paper``: NeRF's (the report's)."""


PICKED = {"first": "the first N", "spread": "N spread over the directions"}
"""The choices of ``Config.pick``, in words."""
NEAREST = "7, the 5 views nearest view 101"
"""The additions' row on a file's data that trains on the 5 photos seen from closest to the report's test view
(:func:`nearest_views`): how far the report's one-view score depends on which 5 photos, against every held-out view."""


@dataclass
class Config:
    """The table's objects, budgets and architecture."""

    objects: tuple = setting(("brick", "vase"), selects=True)
    """3D objects of ours (``brick``: thin parts and printed detail, like the report's Lego)."""
    data: str | None = setting(None)
    """The report's own data instead of our objects: a tiny-NeRF ``.npz`` (its first 100 views are the pool, view
    101 the report's test view, views 100 to 105 the held-out views of our protocol)."""
    resolution: int = setting(100, lo=1, hi=16384)
    """Photo width and height in pixels (the report's data: 100 x 100)."""
    pool_views: int = setting(200, lo=1, hi=100_000)
    """Photos rendered per object; a run with N images uses N of them (``pick``)."""
    pick: str = setting("first", choices=tuple(PICKED))
    """Which N photos of the pool a row with N images trains on: ``first``, the pool's first N (the order they were
    taken or rendered in); ``spread``, N far apart (:func:`spread_views`: the first photo, then each time the one
    whose camera sees the object from furthest from those taken), the report's "5 images from different angles"
    read as a photographer picks them. A pool's first few photos may all face one side (the tiny-NeRF Lego's first 5
    leave a 168 degree gap in azimuth, which holds view 101)."""
    test_views: int = setting(16, lo=1, hi=100_000)
    """Noise-free test views on the 360 degree orbit."""
    combinations: tuple = setting(tuple(COMBINATIONS), choices=tuple(COMBINATIONS), selects=True)
    """Which of the report's combinations to run."""
    architecture: str = setting("ours", choices=tuple(ARCHITECTURES))
    """``ours`` or ``paper`` (``ARCHITECTURES``)."""
    few_views: int = setting(0, lo=0, hi=100_000)
    """Rows of at most this many images open their positional encoding's frequencies over ``pe_window`` steps
    (FreeNeRF's frequency regularisation, ``NeRFConfig.pe_window``): fitted to few views, the field otherwise
    explains each with fine detail that the other views never see, floaters in a new one; 0: no row, the report's
    NeRF. The additions table has row 7 the other way."""
    pe_window: int = setting(1000, lo=1, hi=10 ** 9, unit="steps")
    """The few-view rows' window (half the report's 2000 iterations); a row with more steps scales it alike."""
    iters: int = setting(2000, lo=1, hi=10 ** 9)
    """Steps per row at most (the report's)."""
    lr_decay: bool = setting(False)
    """Decay each row's learning rate over its budget as the ``vanilla-3d`` recipe does (to its ``lr_final``); off:
    the recipe's ``lr`` throughout, the report's schedule: NeRF's tenfold decay over 250,000 steps lowers its rate by
    2 % in 2000 iterations. A file's rows are also scored on pool views they do not train on (``pool_scored``), the
    check of this choice that leaves every test view alone; the additions table runs row 6 the other way."""
    pool_scored: int = setting(12, lo=0, hi=100_000)
    """With a file's data, each row is also scored on this many of the pool's photos it does not train on, evenly
    spread over them (a validation: neither view 101 nor the held-out views); 0: none."""
    batch_rays: int = setting(1024, lo=1, hi=1 << 22)
    """Rays per step."""
    time_budget: float = setting(120.0, lo=0, above=True, hi=10 ** 7)
    """Seconds of training per row (the same for every row)."""
    additions: bool = setting(True, selects=True)
    """Also run our additions table."""
    addition_views: tuple = setting((5, 200), lo=1, hi=100_000, selects=True)
    """Photo counts of the grid and hash-grid rows (the fine pass runs at 5 and 25)."""
    seed: int = setting(0, lo=0, hi=2 ** 31)
    """Seed of the photos' placement and of every training."""
    quick: bool = setting(False)
    """A smoke run: its report judges nothing."""


def quick(seed: int = 0) -> Config:
    return Config(objects=("vase",), resolution=32, pool_views=12, test_views=4, combinations=(7, 8),
                  iters=40, time_budget=6.0, addition_views=(5,), seed=seed, quick=True)


def _recipe(name: str, cfg: Config, steps: int = 1, **settings):
    """Recipe ``name`` with ``settings``, ``steps`` times the row's time budget, no validation."""
    return get_recipe(name).override(**settings, time_budget=steps * cfg.time_budget, val_every=0, seed=cfg.seed)


def nerf_recipe(cfg: Config, images: int, L: int, n_coarse: int, vd: bool, n_fine: int = 0, steps: int = 1,
                **arch):
    """The report's NeRF for ``images`` at (L, N_c, view dependence), with the frequency window where the images are
    few (``cfg.few_views``) and the learning rate of ``cfg.lr_decay``; ``steps`` times the steps and budget;
    ``arch``: MLP settings (and ``lr_decay``, this row's own)."""
    lr_decay = arch.pop("lr_decay", cfg.lr_decay)
    if images <= cfg.few_views:
        arch = {"pe_window": steps * cfg.pe_window, **arch}
    recipe = _recipe("vanilla-3d", cfg, steps, **{**ARCHITECTURES[cfg.architecture], **arch}, pos_L=L,
                     n_coarse=n_coarse, n_fine=n_fine, view_dependent=vd, iters=steps * cfg.iters,
                     batch_rays=cfg.batch_rays)
    return recipe if lr_decay else recipe.override(lr_final=recipe.train.lr)


def unit_directions(origins) -> np.ndarray:
    """The directions ``[P, 3]`` from the object (at the origin) to the cameras at ``origins`` ``[P, 3]``."""
    u = np.asarray(origins, np.float64)
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


def spread_views(origins: np.ndarray, n: int) -> np.ndarray:
    """Indices of ``n`` of the cameras at ``origins`` ``[P, 3]`` (around an object at the origin) whose directions
    from the object lie far apart: the first camera, then each time the one whose smallest angle to those taken is
    largest (farthest-point sampling on the unit sphere; ties to the lower index). ``[n]``, in the order taken::

        spread_views([[1, 0, 0], [0.9, 0.1, 0], [-1, 0, 0], [0, 1, 0]], 3)   # [0, 2, 3]: opposite, then between
    """
    u = unit_directions(origins)
    n = min(int(n), len(u))
    if n < 1:
        return np.zeros(0, np.int64)
    taken, nearest = [0], u @ u[0]                  # cosine of each camera's smallest angle to those taken
    for _ in range(n - 1):
        nearest[taken] = np.inf
        taken.append(int(np.argmin(nearest)))
        nearest = np.maximum(nearest, u @ u[taken[-1]])
    return np.asarray(taken, np.int64)


def nearest_views(origins: np.ndarray, target: np.ndarray, n: int) -> np.ndarray:
    """Indices of the ``n`` cameras at ``origins`` ``[P, 3]`` that see the object (at the origin) from the directions
    closest to the camera at ``target`` ``[3]``, nearest first (ties to the lower index). ``[n]``::

        nearest_views([[1, 0, 0], [0, 1, 0], [0.9, 0.1, 0], [-1, 0, 0]], [1, 0.2, 0], 2)   # [2, 0]: 5, then 11 deg
    """
    return np.argsort(-(unit_directions(origins) @ unit_directions(target)), kind="stable")[:max(0, int(n))]


def training_indices(cfg: Config, pool: Split, n) -> np.ndarray:
    """Indices of the ``n`` photos of ``pool`` a row trains on (``cfg.pick``), or ``n`` itself (an array)."""
    if not np.isscalar(n):
        return np.asarray(n, np.int64)
    if cfg.pick == "spread":
        return spread_views(pool.cameras.origins, n)
    return np.arange(min(int(n), len(pool)), dtype=np.int64)


def unused_views(size: int, taken, n: int) -> np.ndarray:
    """``n`` of the indices below ``size`` not in ``taken``, evenly spread over them (all where fewer remain)::

        unused_views(10, [0, 1, 2], 3)    # [3, 6, 9]: of 3..9, the first, the middle and the last
    """
    rest = np.setdiff1d(np.arange(size), np.asarray(taken, np.int64))
    if n <= 0 or len(rest) == 0:
        return np.zeros(0, np.int64)
    return rest[np.unique(np.round(np.linspace(0, len(rest) - 1, min(n, len(rest)))).astype(np.int64))]


def panels(rows: list[dict]) -> list[dict]:
    """The chart of its rows (:func:`~mitnerf.viz.panels.series_figure`): Table 2 and ours on each object, row for
    row."""
    pts = [{"#": i, "psnr": c[4], "run": "Table 2 (Lego, GPU)"} for i, c in COMBINATIONS.items()]
    pts += [{"#": i, "psnr": rs[str(i)].get("psnr"), "run": f"ours, {obj}"} for obj, rs in _ws(rows).items()
            for i in COMBINATIONS if str(i) in rs]
    return [dict(title="window shopping: Table 2 row for row", rows=pts, x="#", by=("run",), err=False,
                 xlabel="combination", xticks=list(COMBINATIONS), styles={p["run"]: "o" for p in pts[::-1]} | {
                     pts[0]["run"]: "ks"})]


def sources(cfg: Config) -> dict:
    """``{name: (pool of training views, {protocol: test split})}``: our objects (their test orbit), or the data of
    ``cfg.data`` (the report's protocol, view 101 alone, and ours, every held-out view)."""
    if cfg.data is None:
        return {obj: (ds, {"ours": ds["test"]}) for obj in cfg.objects for ds in [cached_dataset(obj, RigConfig(
            dim=3, n_train=cfg.pool_views, n_val=2, n_test=cfg.test_views, resolution=cfg.resolution, seed=cfg.seed,
            **noise_preset(1.0)))]}
    ds = load_dataset(cfg.data)
    held = Split.concatenate([ds[s] for s in ("val", "test") if s in ds.splits])
    if len(ds["train"]) < 100 or len(held) < 2:
        raise DataError(f"{cfg.data}: the report's protocol needs 100 training views and view 101 held out "
                        f"(the tiny-NeRF Lego's layout); this file has {len(ds['train'])} and {len(held)}")
    return {ds.name: (ds, {"report": held.subset([1]), "ours": held})}


def run(cfg: Config, out: Path) -> list[dict]:
    rows, thumbs = [], {}
    for obj, (ds, tests) in sources(cfg).items():
        jobs = [(f"{i}", "report", COMBINATIONS[i][0], nerf_recipe(cfg, *COMBINATIONS[i][:4]))
                for i in cfg.combinations]
        if cfg.additions:
            windowed = cfg.few_views >= 5                     # row 7 has the window: its addition has none
            jobs += [("9, twice the steps", "additions", 5, nerf_recipe(cfg, 5, 10, 64, True, steps=2)),
                     ("6, view dependence on", "additions", 10, nerf_recipe(cfg, 10, 6, 64, True)),
                     ("6, constant learning rate" if cfg.lr_decay else "6, decaying learning rate", "additions", 10,
                      nerf_recipe(cfg, 10, 6, 64, False, lr_decay=not cfg.lr_decay)),
                     ("7, four direction frequencies", "additions", 5, nerf_recipe(cfg, 5, 6, 64, True, dir_L=4)),
                     ("7, no frequency window" if windowed else "7, frequency window", "additions", 5,
                      nerf_recipe(cfg, 5, 6, 64, True, pe_window=0 if windowed else cfg.pe_window))]
            pool = len(ds["train"])                   # the photos there are: a file's 100 views, or pool_views
            jobs += [(f"fine pass, {v} images", "additions", v, nerf_recipe(cfg, v, 10, 64, True, n_fine=64))
                     for v in (5, 25) if v <= pool]
            jobs += [(f"{name} recipe, {v} images", "additions", v, _recipe(name, cfg))
                     for v in sorted({min(v, pool) for v in cfg.addition_views}) for name in ("grid-3d", "hashgrid-3d")]
            if "report" in tests:           # the report's protocol scores one view: row 7 on the 5 photos around it
                near = nearest_views(ds["train"].cameras.origins, tests["report"].cameras.origins[0], 5)
                jobs.append((NEAREST, "additions", near, nerf_recipe(cfg, 5, 6, 64, True)))
        for label, table, views, recipe in jobs:
            first, *more = tests
            taken = training_indices(cfg, ds["train"], views)
            data = Dataset({"train": ds["train"].subset(taken), "test": tests[first]}, ds.near, ds.far, dict(ds.meta))
            row, run, rec = train_row(data, recipe.override(background=ds.background),
                                      {"object": obj, "table": table, "row": label, "images": len(data["train"])})
            unused = unused_views(len(ds["train"]), taken, cfg.pool_scored) if "report" in tests else []
            others = {p: tests[p] for p in more} | ({"pool": ds["train"].subset(unused)} if len(unused) else {})
            for protocol, split in others.items():     # the same model on the other test views and the validation
                other = run.record(Dataset({"test": split}, ds.near, ds.far, dict(ds.meta)), geometry_metrics=False)
                row.update({f"psnr_{protocol}": other.psnr, f"ssim_{protocol}": other.ssim})
            if table == "report":
                _, L, nc, vd, theirs = COMBINATIONS[int(label)]
                row.update(L=L, N_c=nc, view_dependence=vd, report_psnr=theirs)
            rows.append(row)
            if rec.renders is not None:
                thumbs[(obj, label)] = rec.renders["rgb"][0]
    write_csv(out / "results.csv", rows)
    _draw(cfg, rows, thumbs, out)
    _write(cfg, rows, out)
    return rows


def _draw(cfg: Config, rows: list[dict], thumbs: dict, out: Path) -> None:
    """``psnr_vs_views.png`` (:func:`panels`) and ``thumbnails.png`` (the first test view of every row of the report's
    table)."""
    series_figure(out / "psnr_vs_views.png", panels(rows), cell=(6, 3.8))
    image_grid(out / "thumbnails.png", [[(image_panel, img, f"{obj} #{row}") for (o, row), img in thumbs.items()
                                         if o == obj and row.isdigit()] for obj in _ws(rows)], cell=(1.6, 1.8))


def tables(rows: list[dict]) -> tuple[str, str]:
    """The report's Table 1 and 2 row for row beside ours on each object, and our additions (markdown tables)."""
    objs, table = _ws(rows), []
    for i, (images, L, nc, vd, theirs) in COMBINATIONS.items():
        row = {"#": i, "images": images, "L": L, "N_c": nc, "view dep.": "on" if vd else "off",
               "Table 2 PSNR": f"{theirs:.1f}"}
        for obj, rs in objs.items():
            r, two = rs.get(str(i), {}), any("psnr_ours" in x for x in rs.values())     # the report's data: 2 tests
            score = f"{_f(r.get('psnr'), '.2f')} / {_f(r.get('ssim'), '.3f')}"
            row[f"{obj} {'view 101' if two else 'PSNR / SSIM'}"] = score
            if two:
                row[f"{obj} held-out views"] = f"{_f(r.get('psnr_ours'), '.2f')} / {_f(r.get('ssim_ours'), '.3f')}"
            if any("psnr_pool" in x for x in rs.values()):
                row[f"{obj} unused pool views"] = _f(r.get("psnr_pool"), ".2f")
            row[f"{obj} steps, s"] = f"{_f(r.get('steps'), '.0f')}, {_f(r.get('train_time'), '.0f')}"
        table.append(row)
    held = any("psnr_ours" in r for rs in objs.values() for r in rs.values())     # the report's data: 2 tests
    pool = any("psnr_pool" in r for rs in objs.values() for r in rs.values())
    add = [{"row": label, "object": obj, "images": r.get("images"), "PSNR": _f(r.get("psnr"), ".2f"),
            "SSIM": _f(r.get("ssim"), ".3f"), **({"held-out PSNR": _f(r.get("psnr_ours"), ".2f")} if held else {}),
            **({"unused pool PSNR": _f(r.get("psnr_pool"), ".2f")} if pool else {}),
            "Chamfer": _f(r.get("chamfer"), ".4f"), "steps": r.get("steps"), "train s": _f(r.get("train_time"), ".0f")}
           for obj, rs in objs.items() for label, r in rs.items() if not label.isdigit()]
    return markdown_table(table), "Our additions:\n\n" + markdown_table(add)


def lr_words(config: dict) -> str:
    """The rows' learning-rate schedule in words, from a run's config (``lr_decay``; a record without it decayed)."""
    return ("the learning rate decaying as the recipe's" if config.get("lr_decay", True)
            else "a constant learning rate (NeRF's over 2000 iterations)")


def _write(cfg: Config, rows: list[dict], out: Path) -> None:
    arch, (table, add) = ARCHITECTURES[cfg.architecture], tables(rows)
    n_images = PICKED[cfg.pick]
    data = (f"The report's own data, {cfg.data}: N images = {n_images} of its first 100 views; each row is scored by "
            "the report's protocol (view 101) and by ours (every held-out view, 100 to 105); the additions' row "
            f"\"{NEAREST}\" trains on the 5 seen from closest to view 101. Unused pool views: the validation, "
            f"{cfg.pool_scored} of the first 100 views the row does not train on, evenly spread." if cfg.data else
            f"Objects {', '.join(cfg.objects)}, {cfg.resolution} x {cfg.resolution} photos (random, noisy, upper "
            f"hemisphere; N images = {n_images} of one pool), {cfg.test_views} test views on the 360 degree orbit.")
    few = (f"rows of at most {cfg.few_views} images open their positional encoding's frequencies over the first "
           f"{cfg.pe_window} steps (FreeNeRF's frequency regularisation; the report's NeRF has none)"
           if cfg.few_views else "no frequency window")
    write_report(out, "Window shopping: the report's table, row for row", [
        ("Set-up", f"{data} NeRF: recipe `vanilla-3d` with the {cfg.architecture} MLP ({arch['depth']} x "
                   f"{arch['width']}, skip into layer {arch['skip']}, {arch['dir_L']} direction frequencies), no fine "
                   f"pass; every row at most {cfg.iters} steps of {cfg.batch_rays} rays and {cfg.time_budget:g} s; "
                   f"{few}; {lr_words(vars(cfg))}. "
                   f"Deviations from the report: {'' if cfg.data else 'our objects (not the tiny-NeRF Lego), '}CPU "
                   "(2 cores) instead of a GPU, a time cap per row."),
        ("The report's combinations", table),
        ("Our additions", add + "\n![PSNR against images](psnr_vs_views.png)\n\n"
                                "![first test view of every row](thumbnails.png)"),
    ], cfg.quick, lambda: judged("window-shop", rows))
