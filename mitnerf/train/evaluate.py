"""One evaluation for every caller: ``evaluate(...) -> RunRecord``, with one status from :func:`classify`,
the only definition of a failed run in mitnerf: ``nan`` (a render or the loss is not finite), ``collapsed``
(*empty*: mean opacity below ``EMPTY_OPACITY`` on pixels whose ground-truth coverage exceeds 0.5, or
*constant*: render standard deviation below ``CONSTANT_STD`` while the target varies), else ``ok``."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import Dataset, Split
from ..data.rays import background_name
from ..geometry import LEVEL, chamfer_distance, extract_mesh, mesh_from_ply
from ..geometry.outline import outline_iou
from .metrics import depth_error, psnr, ssim

EMPTY_OPACITY = 0.1
"""Mean opacity on the object's pixels below which a field counts as empty."""
CONSTANT_STD = 1e-3
"""Standard deviation of the renders below which they count as constant."""


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
    params: int = 0
    """Trainable parameters of the model."""
    recipe: str = ""
    """The recipe's name (``+`` when settings were overridden)."""
    background: str = ""
    """What the test renders and their targets are composited over (``white``, ``black``, ``r,g,b``; a
    ``random`` training background evaluates over white)."""
    renders: dict | None = field(default=None, repr=False)
    """The test renders (``rgb``, ``depth``, ``opacity`` as ``[n, H, W, ...]``); not in :meth:`row`."""

    def row(self) -> dict:
        """A flat dict for CSV files and tables (without the renders)."""
        return {k: v for k, v in dataclasses.asdict(self).items() if k != "renders"}

    def line(self) -> str:
        """One line, the last thing ``mitnerf fit`` prints."""
        extra = "".join(f", {name} {getattr(self, key):{fmt}}" for name, key, fmt in
                        (("SSIM", "ssim", ".3f"), ("IoU", "iou", ".3f"), ("Chamfer", "chamfer", ".4f"))
                        if math.isfinite(getattr(self, key)))
        status = "" if self.status == "ok" else f" [{self.status}: {self.reason}]"
        return f"test PSNR {self.psnr:.2f} dB{extra}, train {self.train_time:.1f} s, recipe {self.recipe}{status}"


def classify(rgb: np.ndarray, opacity: np.ndarray, split: Split, background) -> tuple[str, str]:
    """The status of renders of ``split`` (``rgb [n, H, W, 3]``, ``opacity [n, H, W]``)."""
    if not (np.isfinite(rgb).all() and np.isfinite(opacity).all()):
        return "nan", "the renders contain NaN or infinity"
    obj = split.alpha > 0.5
    if obj.any() and (~obj).any():
        mean = float(opacity[obj].mean())
        if mean < EMPTY_OPACITY:
            return "collapsed", f"empty: mean opacity on the object {mean:.3f} < {EMPTY_OPACITY}"
    spread = float(np.std(rgb))
    if spread < CONSTANT_STD and float(np.std(split.target(background))) > 1e-2:
        return "collapsed", f"constant: render standard deviation {spread:.1e} < {CONSTANT_STD:g}"
    return "ok", ""


def render_split(backend, split: Split) -> tuple[dict, float]:
    """Renders of ``split``'s views ``[n, H, W, ...]`` (``eval_spp`` rays per pixel), and the seconds taken."""
    o, d = split.cameras.rays()
    D, t0 = o.shape[-1], time.perf_counter()
    out = backend.render(o.reshape(-1, D), d.reshape(-1, D), footprint=split.cameras.footprint().reshape(-1, 2, D),
                         spp=backend.model_cfg.render.eval_spp)
    elapsed = time.perf_counter() - t0
    return {k: v.reshape(*o.shape[:-1], *v.shape[1:]) for k, v in out.items()}, elapsed


def geometry(backend, dataset: Dataset, bound: float, resolution: int | None = None) -> dict:
    """IoU (2D, when the dataset knows its outline) or Chamfer distance (3D, when it knows its mesh)."""
    meta = dataset.meta
    if dataset.dim == 2 and meta.get("polygon") is not None:
        return {"iou": outline_iou(backend.density, np.asarray(meta["polygon"]), bound, resolution or 256)}
    if dataset.dim == 3 and meta.get("mesh"):
        try:
            truth = mesh_from_ply(meta["mesh"])
            mesh = extract_mesh(backend.density, bound, resolution or 96, level=LEVEL, progress=False)
        except Exception:           # noqa: BLE001 - no surface at the level, a moved mesh file: no figure
            return {}
        return {"chamfer": chamfer_distance(mesh, truth, n_points=30_000).chamfer}
    return {}


def evaluate(backend, dataset: Dataset, split: str = "test", *, geometry_metrics: bool = True,
             record: RunRecord | None = None) -> RunRecord:
    """Render ``split`` and measure it; fills (and returns) ``record``."""
    rec = record or RunRecord()
    s = dataset[split]
    bg = backend.model_cfg.render.render_background()
    rec.background = background_name(bg)
    r, elapsed = render_split(backend, s)
    target = s.target(bg)
    rec.renders = r
    rec.render_time = elapsed / max(len(s), 1)
    rec.params = backend.n_params()
    status, reason = classify(r["rgb"], r["opacity"], s, bg)
    if rec.status == "ok":
        rec.status, rec.reason = status, reason
    if status == "nan":
        return rec
    rec.psnr, rec.ssim = psnr(r["rgb"], target), ssim(r["rgb"], target)
    if s.depth is not None:
        mask = s.mask if s.mask is not None else np.isfinite(s.depth)
        rec.depth_error = depth_error(r["depth"], r["opacity"], s.depth, mask)
    if geometry_metrics:
        for k, v in geometry(backend, dataset, backend.bound).items():
            setattr(rec, k, v)
    return rec
