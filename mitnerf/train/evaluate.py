"""One evaluation for every caller: ``evaluate(...) -> RunRecord``, with one status from :func:`classify`,
the only definition of a failed run in mitnerf: ``nan`` (a render or the loss is not finite), ``collapsed``
(*empty*: mean opacity below ``EMPTY_OPACITY`` on pixels whose ground-truth coverage exceeds 0.5, or
*constant*: render standard deviation below ``CONSTANT_STD`` while the target varies), else ``ok``."""

from __future__ import annotations

import dataclasses
import math
import resource
import time
from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from ..data.dataset import Dataset, Split
from ..geometry import field_chamfer, mesh_from_ply
from ..data.rays import background_name
from ..geometry.outline import outline_iou
from .metrics import depth_error, ssim

EMPTY_OPACITY = 0.1
"""Mean opacity on the object's pixels below which a field counts as empty."""
CONSTANT_STD = 1e-3
"""Standard deviation of the renders below which they count as constant."""
CHUNK_RAYS = 1 << 19
"""Rays rendered (whole views) before they are measured."""
KEPT_PIXELS = 1 << 22
"""Pixels of test renders kept for the figures (all views of a small split, evenly spaced ones of a large one)."""


@dataclass
class RunRecord:
    """What a run reached (every experiment, the sweep and ``fit --auto`` use this record)."""

    status: str = "ok"
    """``ok``, ``collapsed``, ``nan`` or ``failed`` (see the module docstring)."""
    reason: str = ""
    """Why a run is not ``ok``."""
    psnr: float = math.nan
    """Test PSNR (dB) over the dataset's background."""
    ssim: float = math.nan
    """Test SSIM."""
    depth_error: float = math.nan
    """Mean absolute error of the termination depth on pixels that hit the object."""
    iou: float = math.nan
    """2D: IoU of the field's solid with the true outline."""
    chamfer: float = math.nan
    """3D: Chamfer distance of the density mesh to the true mesh (world units)."""
    train_time: float = math.nan
    """Seconds of training (validation excluded)."""
    steps: int = 0
    """Optimisation steps taken."""
    render_time: float = math.nan
    """Seconds to render one test view."""
    eval_time: float = math.nan
    """Seconds the evaluation took: rendering, metrics, geometry."""
    views: int = 0
    """Test views measured: all of the split's, or ``--test-views`` evenly spaced ones (:func:`test_views`)."""
    split_views: int = 0
    """Views in the test split."""
    peak_memory: float = math.nan
    """GiB: the process's peak resident memory when the evaluation ended (loading, training and evaluating); raised
    to the peak at the end of the checkpoint's writing where the run is written (:func:`~.checkpoint.write_fit`)."""
    params: int = 0
    """Trainable parameters of the model."""
    recipe: str = ""
    """The recipe's name (``+`` when settings were overridden)."""
    background: str = ""
    """What the test renders and their targets are composited over (``white``, ``black``, ``r,g,b``; a
    ``random`` training background evaluates over white)."""
    renders: dict | None = field(default=None, repr=False)
    """Test renders kept for the figures (``rgb``, ``depth``, ``opacity`` as ``[n, H, W, ...]``, ``views``: their
    indices in the split); not in :meth:`row`."""

    def row(self) -> dict:
        """A flat dict for CSV files and tables (without the renders)."""
        return {k: v for k, v in dataclasses.asdict(self).items() if k != "renders"}

    def line(self) -> str:
        """One line, the last thing ``mitnerf fit`` prints."""
        extra = "".join(f", {name} {getattr(self, key):{fmt}}" for name, key, fmt in
                        (("SSIM", "ssim", ".3f"), ("IoU", "iou", ".3f"), ("Chamfer", "chamfer", ".4f"))
                        if math.isfinite(getattr(self, key)))
        status = "" if self.status == "ok" else f" [{self.status}: {self.reason}]"
        some = f" on {self.views} of {self.split_views} views" if self.views < self.split_views else ""
        return (f"test PSNR {self.psnr:.2f} dB{extra}{some}, train {self.train_time:.1f} s, recipe {self.recipe}"
                f"{status}")


class Tally:
    """Running sums over rendered views: what :func:`classify` and the image metrics need, so a split is measured
    a few views at a time."""

    def __init__(self):
        self.finite, self.n, self.sse, self.ssims = True, 0, 0.0, []
        self.obj = self.obj_opacity = self.background = 0.0
        self.sums = np.zeros(4)          # rgb and target: sum, sum of squares
        self.depth_err = self.depth_n = 0.0

    def add(self, rgb: np.ndarray, opacity: np.ndarray, target: np.ndarray, alpha: np.ndarray,
            metrics: bool = True) -> "Tally":
        """Views ``rgb [k, H, W, 3]``, ``opacity [k, H, W]`` against ``target`` and the true coverage ``alpha``;
        ``metrics``: also the squared error and SSIM of each view."""
        self.finite &= bool(np.isfinite(rgb).all() and np.isfinite(opacity).all())
        obj = alpha > 0.5
        self.obj, self.background = self.obj + obj.sum(), self.background + (~obj).sum()
        self.obj_opacity += float(opacity[obj].sum(dtype=np.float64))
        for k, a in enumerate((rgb, target)):
            self.sums[2 * k:2 * k + 2] += (a.sum(dtype=np.float64), np.square(a, dtype=np.float64).sum())
        self.n += rgb.size
        if metrics and self.finite:
            self.sse += float(np.square(np.clip(rgb, 0, 1) - target, dtype=np.float64).sum())
            self.ssims += [ssim(p[None], t[None]) for p, t in zip(rgb, target)]
        return self

    def add_depth(self, depth: np.ndarray, opacity: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> None:
        """The termination depth's absolute error on the pixels in ``mask`` (see :func:`depth_error`)."""
        if mask.any():
            self.depth_err += depth_error(depth, opacity, truth, mask) * mask.sum()
            self.depth_n += mask.sum()

    def std(self, k: int) -> float:
        mean = self.sums[2 * k] / max(self.n, 1)
        return float(np.sqrt(max(self.sums[2 * k + 1] / max(self.n, 1) - mean * mean, 0.0)))

    def status(self) -> tuple[str, str]:
        """The status of the renders so far (the module docstring)."""
        if not self.finite:
            return "nan", "the renders contain NaN or infinity"
        if self.obj and self.background:
            mean = self.obj_opacity / self.obj
            if mean < EMPTY_OPACITY:
                return "collapsed", f"empty: mean opacity on the object {mean:.3f} < {EMPTY_OPACITY}"
        spread = self.std(0)
        if spread < CONSTANT_STD and self.std(1) > 1e-2:
            return "collapsed", f"constant: render standard deviation {spread:.1e} < {CONSTANT_STD:g}"
        return "ok", ""

    @property
    def psnr(self) -> float:
        mse = self.sse / max(self.n, 1)
        return float("inf") if mse == 0 else float(-10.0 * np.log10(mse))


def classify(rgb: np.ndarray, opacity: np.ndarray, split: Split, background) -> tuple[str, str]:
    """The status of renders of ``split`` (``rgb [n, H, W, 3]``, ``opacity [n, H, W]``)."""
    return Tally().add(rgb, opacity, split.target(background), split.alpha, metrics=False).status()


def render_split(backend, split: Split) -> tuple[dict, float]:
    """Renders of ``split``'s views ``[n, H, W, ...]`` (``eval_spp`` rays per pixel), and the seconds taken."""
    o, d = (a.astype(np.float32) for a in split.cameras.rays())
    spp, D, t0 = backend.model_cfg.render.eval_spp, o.shape[-1], time.perf_counter()
    fp = split.cameras.footprint().reshape(-1, 2, D) if spp > 1 else None
    out = backend.render(o.reshape(-1, D), d.reshape(-1, D), footprint=fp, spp=spp)
    elapsed = time.perf_counter() - t0
    return {k: v.reshape(*o.shape[:-1], *v.shape[1:]) for k, v in out.items()}, elapsed


def test_views(n: int, views: int = 0) -> np.ndarray:
    """The indices of ``views`` evenly spaced views of ``n`` (all of them for 0 or ``views >= n``)."""
    return np.arange(n) if not 0 < views < n else np.unique(np.linspace(0, n - 1, views).round().astype(int))


def geometry(backend, dataset: Dataset, bound: float, resolution: int | None = None) -> dict:
    """IoU (2D, when the dataset knows its outline) or Chamfer distance (3D, when it knows its mesh)."""
    meta = dataset.meta
    if dataset.dim == 2 and meta.get("polygon") is not None:
        return {"iou": outline_iou(backend.density, np.asarray(meta["polygon"]), bound, resolution or 256)}
    if dataset.dim == 3 and meta.get("mesh"):
        try:
            return {"chamfer": field_chamfer(backend.density, bound, mesh_from_ply(meta["mesh"])).chamfer}
        except Exception:           # noqa: BLE001 - no surface at the level, a moved mesh file: no figure
            return {}
    return {}


def evaluate(backend, dataset: Dataset, split: str = "test", *, geometry_metrics: bool = True,
             record: RunRecord | None = None, views: int = 0, progress: bool = False) -> RunRecord:
    """Render ``split`` (``views`` evenly spaced views of it, :func:`test_views`; 0: all) a few views at a time and
    measure it; fills (and returns) ``record``. The renders of at most :data:`KEPT_PIXELS` pixels' worth of views,
    evenly spaced, are kept for the figures (``renders['views']``: their indices in the split)."""
    rec, t0 = record or RunRecord(), time.perf_counter()
    s = dataset[split]
    bg = backend.model_cfg.render.render_background()
    rec.background, rec.params = background_name(bg), backend.n_params()
    index = test_views(len(s), views)
    rec.views, rec.split_views = len(index), len(s)
    pixels = s.cameras.height * s.cameras.width
    keep = set(index[test_views(len(index), max(1, KEPT_PIXELS // pixels))].tolist())
    kept: dict = {"rgb": [], "depth": [], "opacity": [], "views": []}
    tally, rendering = Tally(), 0.0
    step = max(1, CHUNK_RAYS // pixels)
    bar = tqdm(total=len(index), desc=f"{split} views", unit="view", disable=not progress, leave=False)
    for start in range(0, len(index), step):
        part = index[start:start + step]
        sub = s.subset(part).unpacked()              # a packed split: these views unpacked once
        r, elapsed = render_split(backend, sub)
        rendering += elapsed
        tally.add(r["rgb"], r["opacity"], sub.target(bg), sub.alpha)
        if sub.depth is not None:
            tally.add_depth(r["depth"], r["opacity"], sub.depth, sub.mask if sub.mask is not None
                            else np.isfinite(sub.depth))
        for k, v in enumerate(part.tolist()):
            if v in keep:
                for key in ("rgb", "depth", "opacity"):
                    kept[key].append(r[key][k])
                kept["views"].append(v)
        bar.update(len(part))
        bar.set_postfix_str(f"{bar.n * pixels / max(rendering, 1e-9) / 1e3:.0f} k rays/s", refresh=False)
    bar.close()
    rec.renders = {k: np.stack(v) for k, v in kept.items()}
    rec.render_time = rendering / max(len(index), 1)
    status, reason = tally.status()
    if rec.status == "ok":
        rec.status, rec.reason = status, reason
    if status != "nan":
        rec.psnr, rec.ssim = tally.psnr, float(np.mean(tally.ssims))
        rec.depth_error = tally.depth_err / tally.depth_n if tally.depth_n else math.nan
        if geometry_metrics:
            for k, v in geometry(backend, dataset, backend.bound).items():
                setattr(rec, k, v)
    rec.eval_time = time.perf_counter() - t0
    rec.peak_memory = peak_memory()
    return rec


def peak_memory() -> float:
    """The process's peak resident memory so far, GiB: Linux's ``VmHWM``, this program's own (``getrusage`` keeps
    the larger of it and the parent's size when it was started, carried over fork and exec), else ``getrusage``."""
    try:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmHWM")) / 2 ** 20     # KiB
    except (OSError, StopIteration, ValueError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20      # KiB on Linux
