"""Every verdict drawn from our rows: the claims of the two source reports, the stability findings, the sweep's
goal. The experiments return rows and draw figures; only this module judges, and the experiments' reports and
``REPRODUCTION.md`` both quote it.

Every :class:`Claim` quotes its report verbatim and judges the rows of one experiment of ours (as run, or as
recorded in ``results.json`` under ``experiment/<name>``) in one function, its ``judge``. Sources: ``nerf2d``, the
NeRF2D blog post; ``window-shop``, Zhengxun Wu, "Online Window Shopping with NeRF" (Stanford CS231n).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from .report import is_reference, markdown_table, num, pareto_front, summarise

SOURCES = {
    "nerf2d": ("Scaling Down NeRF with NeRF2D (blog post, PyTorch Lightning, laptop GPU)",
               "our 2D scenes (the same four outlines, rendered by Mitsuba), 50 noisy training views of 100 px "
               "where not stated otherwise, 20 evenly spaced test views; Dr.Jit on 2 CPU cores; an MLP of 4 x 32 "
               "(theirs: NeRF's architecture)"),
    "window-shop": ("Z. Wu, Online Window Shopping with NeRF (course report, tiny-NeRF Lego 100 x 100, GPU)",
                    "our objects (brick: thin parts and printed detail like the Lego; vase) at 100 x 100, test views "
                    "on the 360 degree orbit; 2 CPU cores; our MLP (4 x 64, one direction frequency) by default; "
                    "1024 rays per step; the same time budget for every row"),
}
"""Each source's title with its set-up, and what differs in all our rows."""

REPRODUCED, PARTLY, NOT, MISSING = "reproduced", "partly", "not reproduced", "not run"


@dataclass(frozen=True)
class Claim:
    """One claim of a source report."""

    key: str
    """Short id (``pe-trend``)."""
    source: str
    """``nerf2d`` or ``window-shop`` (:data:`SOURCES`)."""
    where: str
    """Section, table or figure of the report."""
    quote: str
    """A short passage of the report, verbatim."""
    theirs: str
    """The report's figure or trend."""
    experiment: str
    """The experiment (``mitnerf experiment NAME``) that measures ours."""
    judge: Callable[[list[dict]], tuple[str, str]]
    """Rows of that experiment -> (our figure, ``REPRODUCED``/``PARTLY``/``NOT`` + the measured cause)."""
    deviations: str
    """What differs from the report for this claim (beyond the source's shared deviations), how it is judged."""


def _f(v, spec=".1f") -> str:
    return "-" if not math.isfinite(num(v)) else format(num(v), spec)


def _key(v):
    """CSV and JSON round trips turn ints into strings; compare as numbers where they are."""
    try:
        return int(v)
    except (TypeError, ValueError):
        return v


def _means(rows: list[dict], by: list[str], metrics=("psnr", "ssim", "iou", "depth_error", "train_time", "steps")):
    """{values of ``by``: the summary of those rows}, the ``by`` values read as numbers where they are."""
    rows = [{**r, **{k: _key(r[k]) for k in by}} for r in rows]
    return {tuple(s[k] for k in by): s for s in summarise(rows, by, metrics)}


# ---------------------------------------------------------------- NeRF2D
def _pe(rows):
    m = _means(rows, ["L"])
    Ls = sorted(k[0] for k in m)
    line = ", ".join(f"L={L}: {_f(m[(L,)]['psnr'])}" for L in Ls) + " dB"
    low = min(Ls, key=lambda L: abs(L - 1))
    best = max((L for L in Ls if L > low), key=lambda L: m[(L,)]["psnr"], default=low)
    rises = m[(best,)]["psnr"] - m[(low,)]["psnr"]
    return line, f"{REPRODUCED if rises > 1.0 else NOT}: {rises:+.1f} dB from L = {low} to the best, L = {best}"


def _pe_speed(rows):
    s = max(_means(rows, ["L"]).values(), key=lambda s: s["psnr"])
    return (f"{_f(s['train_time'])} s to {_f(s['psnr'])} dB (L = {s['L']}, {int(s['steps'])} steps)",
            f"{REPRODUCED if s['train_time'] < 60 else NOT} on 2 CPU cores")


def _depth_cells(rows):
    cells = {}
    for (scene, views, method), s in _means(rows, ["scene", "views", "method"]).items():
        cells.setdefault((scene, views), {})[method] = s
    return {k: v for k, v in cells.items() if {"NeRF", "DS-NeRF"} <= set(v)}


def _depth(rows):
    cells = _depth_cells(rows)
    n = len(cells)
    depth = sum(c["DS-NeRF"]["depth_error"] < c["NeRF"]["depth_error"] for c in cells.values())
    psnr = sum(c["DS-NeRF"]["psnr"] > c["NeRF"]["psnr"] for c in cells.values())
    views = sorted({v for _, v in cells})
    gain = {v: sum(c["DS-NeRF"]["psnr"] - c["NeRF"]["psnr"] for (s, w), c in cells.items() if w == v)
            / max(1, sum(1 for (_, w) in cells if w == v)) for v in views}
    line = (f"DS-NeRF ahead in depth error {depth}/{n}, in PSNR {psnr}/{n} cells; mean PSNR gain "
            + ", ".join(f"{v} views {gain[v]:+.1f} dB" for v in views))
    sparse_first = views and gain[views[0]] >= gain[views[-1]]
    verdict = REPRODUCED if depth == n and psnr >= 0.75 * n and sparse_first else PARTLY if depth >= n / 2 else NOT
    return line, verdict + ("" if sparse_first else ": the gain is not largest at the fewest views")


def _depth_scene(scene):
    def judge(rows):
        cells = {v: c for (s, v), c in _depth_cells(rows).items() if s == scene}
        if not cells:
            return "-", MISSING
        line = "; ".join(f"{v} views: IoU {_f(c['NeRF']['iou'], '.2f')} -> {_f(c['DS-NeRF']['iou'], '.2f')}, "
                         f"depth err. {_f(c['NeRF']['depth_error'], '.3f')} -> {_f(c['DS-NeRF']['depth_error'], '.3f')}"
                         for v, c in sorted(cells.items()))
        better = sum(c["DS-NeRF"]["iou"] > c["NeRF"]["iou"] for c in cells.values())
        best_iou = max(c["DS-NeRF"]["iou"] for c in cells.values())
        verdict = REPRODUCED if better == len(cells) and best_iou >= 0.8 else PARTLY if better else NOT
        return "NeRF -> DS-NeRF: " + line, f"{verdict}: best DS-NeRF IoU {best_iou:.2f}"
    return judge


def _pixel(rows):
    m = _means([r for r in rows if r.get("group") == "eval"], ["scene", "method", "k"])
    parts, full, part = [], 0, 0
    scenes = sorted({k[0] for k in m})
    for scene in scenes:
        ks = sorted({k[2] for k in m if k[0] == scene})
        methods = sorted({k[1] for k in m if k[0] == scene and k[1] != "NeRF"})
        best = {k: max(m[(scene, p, k)]["psnr"] for p in methods) - m[(scene, "NeRF", k)]["psnr"] for k in ks}
        parts.append(f"{scene}: best pixelNeRF - NeRF " + ", ".join(f"k={k} {best[k]:+.1f}" for k in ks) + " dB")
        full += best[ks[0]] > 0 and best[ks[-1]] < 0
        part += best[ks[0]] > 0 and best[ks[-1]] < best[ks[0]]
    verdict = REPRODUCED if full == len(scenes) else PARTLY if part else NOT
    return "; ".join(parts), verdict


# ---------------------------------------------------------------- window shopping
def _ws(rows):
    """{object: {row label: row}} (one seed per row)."""
    out: dict = {}
    for r in rows:
        out.setdefault(r["object"], {})[str(r["row"])] = r
    return out


def _per_object(fn, cause=None):
    """A judge from ``fn(rows of one object) -> (figure, ok)``: reproduced on every object, partly on some,
    not on any; where not reproduced everywhere, ``cause({object: rows})`` states the measured cause."""
    def judge(rows):
        by_object = _ws(rows)
        if not by_object:
            return "-", MISSING
        figs = {obj: fn(rs) for obj, rs in by_object.items()}
        oks = [ok for _, ok in figs.values()]
        verdict = REPRODUCED if all(oks) else PARTLY if any(oks) else NOT
        why = cause(by_object) if cause and verdict != REPRODUCED else ""
        return "; ".join(f"{obj}: {fig}" for obj, (fig, _) in figs.items()), verdict + (f": {why}" if why else "")
    return judge


def _psnr(rs, label):
    if label not in rs:
        raise KeyError(f"row {label}")          # not run: the verdict says so, not "not reproduced"
    return num(rs[label].get("psnr"))


def _speed(rs):
    rep = [r for k, r in rs.items() if k.isdigit() and num(r.get("steps")) > 0]
    per = {nc: [num(r["train_time"]) / num(r["steps"]) for r in rep if int(r["N_c"]) == nc] for nc in (64, 128)}
    txt = ", ".join(f"N_c={nc}: {sum(v) / len(v):.3f} s/step" for nc, v in per.items() if v)
    return txt, all(sum(v) / len(v) <= 0.25 for v in per.values() if v)


def _iters(rs):
    d = _psnr(rs, "9, twice the steps") - _psnr(rs, "9")
    return f"combination 9 at twice the steps {d:+.2f} dB", abs(d) < 1.0


def _views(rs):
    p = [_psnr(rs, c) for c in ("7", "4", "1")]
    return f"5 / 25 / 100 images: {' / '.join(_f(v) for v in p)} dB", p[0] < p[1] < p[2]


def _flat(rs):
    p = [_psnr(rs, c) for c in ("7", "4", "1")]
    return f"spread {max(p) - min(p):.1f} dB over 5-100 images (theirs 2.0)", max(p) - min(p) <= 3.0


def _best(rs):
    five = {c: _psnr(rs, c) for c in ("7", "8", "9", "10")}
    best = max(five, key=five.get)
    return (f"best 5-image combination {best} ({five[best]:.1f} dB; 9: {five['9']:.1f} dB)",
            five["9"] >= five[best] - 0.5)


def _nc(rs):
    big, small = _psnr(rs, "3") - _psnr(rs, "1"), _psnr(rs, "8") - _psnr(rs, "7")
    r7, r8 = rs.get("7", {}), rs.get("8", {})
    steps = f"{r7.get('steps', '-')} and {r8.get('steps', '-')} steps, status {r7.get('status')} / {r8.get('status')}"
    return (f"N_c 64 -> 128: 100 images {big:+.1f} dB, 5 images {small:+.1f} dB (rows 7 / 8: {steps})",
            big > 0 and small < 0 and small < big)


def _nc_cause(by_object) -> str:
    """No N_c = 128 row collapses; at 5 photos NeRF's four direction frequencies drop as far."""
    big = [r for rs in by_object.values() for k, r in rs.items() if k in ("8", "10")]
    four = [num(rs.get("7, four direction frequencies", {}).get("psnr")) - _psnr(rs, "7")    # an addition: may be
            for rs in by_object.values()]                                                   # absent (nan, dropped)
    four = [d for d in four if math.isfinite(d)]
    if not big:
        return ""
    low = min(num(r["psnr"]) for r in big)
    text = (f"no N_c = 128 row at 5 images falls below {low:.1f} dB ({min(int(num(r['steps'])) for r in big)}-"
            f"{max(int(num(r['steps'])) for r in big)} steps in the same time)")
    if four:
        text += (f"; a drop of the report's size at 5 images comes with NeRF's four direction frequencies "
                 f"({', '.join(f'{d:+.1f}' for d in four)} dB on row 7), so we read it as view-dependent "
                 "overfitting, not as the number of samples")
    return text


def _hier_cause(by_object) -> str:
    """At equal time the fine pass buys its samples with steps."""
    steps = [num(r.get("steps")) for rs in by_object.values() for k, r in rs.items() if k.startswith("fine pass")]
    steps = [int(v) for v in steps if math.isfinite(v)]
    if not steps:
        return ""
    return (f"at the same time per row the fine pass runs {min(steps)}-{max(steps)} steps instead of up to 2000; "
            "the loss is the steps it costs")


def _hier(rs):
    d = [(v, _psnr(rs, f"fine pass, {v} images") - _psnr(rs, c)) for v, c in ((5, "9"), (25, "5"))]
    d = [(v, x) for v, x in d if math.isfinite(x)]
    return ", ".join(f"{v} images {x:+.2f} dB" for v, x in d), bool(d) and all(abs(x) < 1.0 for _, x in d)


def _vd(rs):
    d = _psnr(rs, "6, view dependence on") - _psnr(rs, "6")
    return f"view dependence on - off (10 images) {d:+.2f} dB", d > 0.3


CLAIMS = [
    Claim("nerf2d-speed", "nerf2d", "Training a 2D NeRF",
          "we can fit a 2D NeRF using 50 views of resolution 100 in under a minute",
          "under 60 s (laptop GPU)", "pe", _pe_speed,
          "-"),
    Claim("pe-low", "nerf2d", "Positional Encoding",
          "without positional encoding $(L=1)$ the learned density field is very low frequency",
          "a blurry, low-frequency density field at L = 1 (figure)", "pe", _pe,
          "density images in the experiment's pe_density.png; L = 0 (raw coordinates) also run"),
    Claim("pe-trend", "nerf2d", "Positional Encoding",
          "as we increase $L$ we can fit higher frequency signals, additionally leading to increased PSNR",
          "PSNR rises with L (figure, no numbers in the text)", "pe", _pe, "two seeds per L"),
    Claim("ds-sparse", "nerf2d", "Depth Supervision",
          "depth supervision greatly increases the visual quality and reconstructed geometry, especially when using "
          "sparse training views", "better renders and geometry at 2, 5 and 10 views (figures)", "depth", _depth,
          "exact pixel-centre depths; lambda and sigma-hat ours (not stated); evenly spaced views"),
    Claim("ds-concave", "nerf2d", "Depth Supervision",
          "NeRF is unable to reconstruct the convexity but DS-NeRF, even with sparse training views accurately "
          "reconstructs the geometry", "the notch of the concave square recovered by DS-NeRF only (figure)", "depth",
          _depth_scene("square_concave"), "geometry scored as IoU with the true outline"),
    Claim("ds-tu", "nerf2d", "Depth Supervision",
          "Depth Supervised NeRF can accurately reconstruct even the complex geometry of the TU Scene",
          "the TU outline recovered (figure)", "depth", _depth_scene("tu"),
          "geometry scored as IoU with the true outline"),
    Claim("pixelnerf", "nerf2d", "Pixel Space Features",
          "PixelNeRF2D outperforms NeRF2D with fewer views but shows worse performance with greater numbers of views",
          "ahead at 1-5 views, behind at 9 (figures on bunny and TU)", "pixelnerf", _pixel,
          "pixelNeRF trained on procedural outlines (frozen random and trained CNN encoders), "
          "3 draws of the input views per k"),
    Claim("ws-speed", "window-shop", "3.1 Model Fine Tuning",
          "the average training speed is 0.25 seconds per iteration", "0.25 s per iteration (GPU)", "window-shop",
          _per_object(_speed), "a CPU, not a GPU; 1024 rays per step (theirs not stated)"),
    Claim("ws-iters", "window-shop", "4.2 Result, observation 1",
          "2000 iterations is a reasonable value in terms of training progress", "2000 iterations", "window-shop",
          _per_object(_iters), "judged as: twice the steps gains under 1 dB"),
    Claim("ws-views", "window-shop", "4.2 Result, observation 2",
          "the more training images, the higher quality of the image", "Table 2 rows 7 / 4 / 1: 23.0 / 25.0 / 23.5 dB",
          "window-shop", _per_object(_views), "judged as: PSNR rises from 5 to 25 to 100 images (rows 7, 4, 1)"),
    Claim("ws-flat", "window-shop", "4.2 Result, observation 3",
          "the PSNR of the rendered image won't be downgraded a lot no matter what the size of the training set is",
          "23.0-25.0 dB from 5 to 100 images", "window-shop", _per_object(_flat), "judged as: spread within 3 dB"),
    Claim("ws-best", "window-shop", "5. Conclusion",
          "with which we are able to synthesize unseen view with a PSNR around 24",
          "best: 5 images, L = 10, N_c = 64 (combination 9), 24.0 dB", "window-shop", _per_object(_best),
          "judged as: combination 9 within 0.5 dB of the best 5-image row"),
    Claim("ws-nc", "window-shop", "5. Conclusion",
          "regresses the model with a smaller training set (experiment 7 & 8)",
          "N_c 64 -> 128: +0.7 dB at 100 images (1 -> 3), -8.0 dB at 5 images (7 -> 8)", "window-shop",
          _per_object(_nc, _nc_cause), "equal time per row: N_c = 128 rows run fewer steps"),
    Claim("ws-hierarchical", "window-shop", "1.3.3 Hierarchical Volume Sampling",
          "it might be the least important factor towards overall image quality",
          "NeRF's ablation: -0.95 dB without it", "window-shop", _per_object(_hier, _hier_cause),
          "fine pass of 64 samples added to combinations 9 and 5; judged as: under 1 dB either way"),
    Claim("ws-view-dependence", "window-shop", "1.3.1 View Dependence",
          "removing view dependency prevents the model from recreating some lighting effects",
          "NeRF's ablation: -3.35 dB without it", "window-shop", _per_object(_vd, lambda _: (
              "our objects are diffuse under point lights: there is no view-dependent effect to recreate")),
          "combination 6 with view dependence switched on; judged as: more than 0.3 dB gain"),
]
"""Every claim with a figure or a trend in the two reports."""


def verdict(claim: Claim, rows: list[dict] | None) -> tuple[str, str]:
    """(our figure, whether ``claim`` stands) from the rows of its experiment; ``MISSING`` where there are none or
    they lack what the judge reads."""
    if not rows:
        return "-", f"{MISSING} (`mitnerf experiment {claim.experiment}`)"
    try:
        return claim.judge(rows)
    except (KeyError, ValueError, ZeroDivisionError) as e:
        return "-", f"{MISSING}: the recorded rows lack {e}"


def claims_table(claims: list[Claim], rows_of: Callable[[str], list[dict] | None]) -> str:
    """The claims with the report's figure and ours and the verdict; ``rows_of(experiment)`` gives the rows."""
    rows = []
    for c in claims:
        ours, stands = verdict(c, rows_of(c.experiment))
        rows.append({"claim": f"\"{c.quote}\" ({c.where})", "theirs": c.theirs, "ours": ours, "stands": stands,
                     "run": f"`{c.experiment}`", "deviations, judged as": c.deviations})
    return markdown_table(rows)


def stability_findings(rows: list[dict]) -> str:
    """What switching each safeguard off does to the runs of the stability experiment."""
    by = {s["method"]: s for s in summarise(rows, ["method"], ("psnr",))}
    base, relu = by.get("NeRF (defaults)"), by.get("NeRF, ReLU + bias 0, no warm-up")
    near = by.get("NeRF, near plane at the camera")
    lines = ["- **Dead density.** With ReLU, a zero density bias and no warm-up, "
             f"{relu['failed']}/{relu['runs']} runs failed ({relu['failures']}); with the defaults (softplus density, "
             f"which always has a gradient; a -1 density bias; a 50-step warm-up) {base['failed']}/{base['runs']}."
             ] if base and relu else []
    lines += [f"- **Floaters in front of the cameras.** With the near plane 5 cm in front of the cameras the median "
              f"test PSNR is {near['psnr_median']:.2f} dB against {base['psnr_median']:.2f} dB with the near plane at "
              "the object's bounding circle (the datasets' default)."] if base and near else []
    return "\n".join(lines + [f"- **{s['method']}**: {s['failed']}/{s['runs']} failed; median {s['psnr_median']:.2f} "
                              f"dB (10-90 %: {s['psnr_p10']:.2f}-{s['psnr_p90']:.2f})." for label, s in by.items()
                              if label in ("DS-NeRF (defaults)", "grid (defaults)")])


SPEEDUP = 100
"""The sweep's goal: the torch reference's test PSNR in 1/SPEEDUP of its wall time."""


def reference_verdict(rows: list[dict]) -> str:
    """Whether some run of the sweep reaches the torch reference's test PSNR in 1/:data:`SPEEDUP` of its wall time."""
    ref = next((r for r in rows if is_reference(r) and r["status"] == "ok"), None)
    if ref is None:
        return "No torch reference in this sweep.\n"
    others = pareto_front([r for r in rows if r["scene"] == ref["scene"] and not is_reference(r)])
    limit = num(ref["wall_time"]) / SPEEDUP
    reach = [r for r in others if num(r["psnr"]) >= num(ref["psnr"])]
    name = lambda r: f"{r['family']} {r['size']} s{r['samples']} {r['backend']} {r['budget']}"
    text = (f"Torch reference ({name(ref)}, {ref['scene']}): {num(ref['psnr']):.2f} dB in "
            f"{num(ref['wall_time']):.1f} s; the goal is that PSNR in at most {limit:.2f} s.\n\n")
    if reach:
        f = reach[0]
        text += (f"- fastest run reaching it: {name(f)}, {num(f['psnr']):.2f} dB in {num(f['wall_time']):.2f} s "
                 f"({num(ref['wall_time']) / num(f['wall_time']):.0f}x faster): "
                 f"**{'PASSED' if num(f['wall_time']) <= limit else 'NOT PASSED'}**\n")
    else:
        text += "- no run reaches it: **NOT PASSED**\n"
    return text


FINDINGS = {"stability": ("Failure modes and what prevents them", stability_findings),
            "sweep": ("Torch reference", reference_verdict)}
"""Per experiment, the section of findings of our own its report ends with, and the function that draws them."""


def judged(experiment: str, rows: list[dict]) -> list[tuple[str, str]]:
    """The sections of an experiment's report that draw conclusions from its ``rows``: the source reports' claims it
    tests, judged as ``REPRODUCTION.md`` judges them, and its :data:`FINDINGS`."""
    claims = [c for c in CLAIMS if c.experiment == experiment]
    out = [("The source reports' claims", claims_table(claims, lambda _: rows))] if claims else []
    return out + ([(FINDINGS[experiment][0], FINDINGS[experiment][1](rows))] if experiment in FINDINGS else [])
