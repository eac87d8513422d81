"""Fitting a field to a dataset: ``fit(dataset, recipe, backend) -> Run``. As it trains (``val_every``,
``val_points``), a few validation views give a PSNR, stop a *collapsed* field (:func:`~.evaluate.classify`; judged
once a quarter of the run has passed) and keep the best weights (the end weights with ``keep_best`` where they
beat the last by ``keep_best_margin``, said in :attr:`Run.notes`). A NaN restores the last good validation's weights. :class:`TrainingFailed` and
:class:`Interrupted` (Ctrl-C, SIGTERM) carry the :class:`Run` so it can be saved and resumed."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import Dataset
from ..data.rays import BACKGROUNDS, background_name
from ..errors import ConfigError, DataError
from ..fields import CONDITIONED
from ..render.space import pick_scene, scene_frame
from .backend import Backend
from .engines import make_backend
from .evaluate import RunRecord, classify, evaluate, render_split
from .loop import Interrupted, LoopState, TrainingFailed, run_loop
from .metrics import psnr
from .recipes import Recipe


@dataclass
class Run:
    """A model being trained, and how it got there."""

    backend: Backend
    recipe: Recipe
    dataset_meta: dict
    """The dataset's provenance (``path`` where it was read from, when known)."""
    state: LoopState = field(default_factory=LoopState)
    best: dict = field(default_factory=dict)
    """``step`` and ``val_psnr`` of the best validation so far (empty before the first)."""
    notes: list = field(default_factory=list)
    """Things the user should know (the best checkpoint was kept, ...)."""
    snapshot: dict | None = field(default=None, repr=False)
    """Weights of the best validation (numpy), kept in memory."""

    @property
    def bound(self) -> float:
        return self.backend.bound

    def record(self, dataset: Dataset, split: str = "test", **kw) -> RunRecord:
        """Evaluate on ``split`` (see :func:`~mitnerf.train.evaluate.evaluate`), the test split on the recipe's
        ``test_views``."""
        rec = RunRecord(train_time=self.state.train_time, steps=self.state.step, recipe=self.recipe.name)
        t = self.recipe.train
        kw = {"views": t.test_views if split == "test" else 0, "progress": t.progress, **kw}
        return evaluate(self.backend, dataset, split, record=rec, **kw)


def check_dataset(dataset: Dataset, need_test: bool = True) -> None:
    """Refuse, before training, a dataset that training or evaluation would fail on."""
    if not dataset.splits.get("train"):
        raise DataError("the dataset has no training views; add views to its train split")
    if need_test and not dataset.splits.get("test"):
        raise DataError("the dataset has no test views, so the fit could not be evaluated; "
                        "add a test split (e.g. `mitnerf dataset --test 20`)")


def resolve_background(recipe: Recipe, dataset: Dataset) -> str:
    """Write the background into ``recipe`` where it has none (the dataset's, :attr:`Dataset.background`, by its
    name where it has one); returns a line that says which and why."""
    r, typed = recipe.model.render, recipe.model.render.background is not None
    if not typed:
        own = tuple(float(v) for v in dataset.background)
        r.background = next((k for k, v in BACKGROUNDS.items() if v == own), own)
    name = background_name(r.background)
    return (f"background {name}" + (" for training, white for evaluation" if name == "random" else "")
            + (" (--background)" if typed else " (the dataset's; --background white|black|random to change)"))


def fit(dataset: Dataset, recipe: Recipe, backend: str = "drjit", *, resume: dict | None = None,
        progress: bool | None = None) -> Run:
    """Train ``recipe`` on ``dataset['train']`` with engine ``backend`` (see the module docstring);
    ``resume``: the state :func:`~mitnerf.train.checkpoint.load_checkpoint` returned, to continue it. Trains a copy
    of ``recipe`` (:attr:`Run.recipe`: sized for the data, its background and scene settled); ``recipe`` is left
    as it was."""
    recipe = recipe.copy()
    scene = settle_scene(recipe, dataset)            # first: a recipe is sized for the scene it is trained in
    recipe = recipe.sized(dataset).validate()
    if recipe.model.field in CONDITIONED:
        raise ConfigError(f"a {recipe.model.field} field renders from input views and trains across scenes; "
                          "run `mitnerf experiment pixelnerf`, or pick another --field")
    if recipe.dim != dataset.dim:
        raise DataError(f"recipe {recipe.name} is for {recipe.dim}D datasets but the dataset is {dataset.dim}D; "
                        f"pick a {dataset.dim}D recipe (`mitnerf recipes`)")
    check_dataset(dataset, need_test=False)
    cfg = recipe.train
    if progress is not None:
        cfg.progress = progress
    resolve_background(recipe, dataset)
    r = recipe.model.render
    bg = r.render_background()
    be = make_backend(backend, recipe.model, cfg, dataset.dim, *scene)
    be.set_data(dataset["train"].rays("random" if r.background == "random" else bg, **cfg.ray_args()))
    c = dataset["train"].cameras
    run = Run(be, recipe, {**dataset.meta, "size": [c.width, c.height]})        # the views' size, as read
    if recipe.model.render.scene != "object":          # the camera path a video follows
        run.dataset_meta["cameras"] = {"poses": c.poses.tolist(), "focal": [float(c.fx[0]), float(c.fy[0])],
                                       "size": [c.width, c.height]}
    if resume is not None:
        be.set_weights(resume["weights"])
        be.load_optimizer_state(resume["optimizer"])
        be.load_sampling_state(resume.get("mining") or {})
        be.step_reached = resume.get("step_reached")
        run.state, run.best = resume["state"], dict(resume.get("best", {}))
        run.snapshot = resume.get("best_weights")
    val = dataset.splits.get("val")             # a few validation views, evenly spread
    val = val.subset(np.linspace(0, len(val) - 1, min(cfg.val_views, len(val))).astype(int)) if val else None
    val = val.unpacked() if val else None       # a packed split: unpacked once, not per validation

    def validate(step: int) -> None:
        r, _ = render_split(be, val)
        status, reason = classify(r["rgb"], r["opacity"], val, bg)
        share = run.state.train_time / cfg.time_budget if cfg.time_budget else step / cfg.iters
        if status != "ok" and step >= 2 * cfg.warmup and share >= 0.25:
            raise TrainingFailed(f"the field {status} by step {step} ({reason}); use a softplus density "
                                 "(--set density_activation=softplus), a lower --lr or a longer warm-up",
                                 status, step)
        value = psnr(r["rgb"], val.target(bg))
        for key, v in (("val_step", step), ("val_time", run.state.train_time), ("val_psnr", value)):
            run.state.history[key].append(v)
        if np.isfinite(value) and value > run.best.get("val_psnr", -np.inf):
            run.best = {"step": step, "val_psnr": value}
            run.snapshot = be.get_weights()

    def restore_best() -> None:
        """The best validation's weights, rendered as at the step they were trained through."""
        be.set_weights(run.snapshot)
        be.step_reached = run.best["step"] - 1

    try:
        run_loop(be.step, be.read, cfg, run.state, validate if val is not None else None,
                 desc=f"fit {recipe.name} ({be.name})")
        if val is not None and run.state.history["val_step"][-1:] != [run.state.step]:
            validate(run.state.step)            # the last step's validation, unless the loop's was the last
    except (TrainingFailed, Interrupted) as exc:
        if isinstance(exc, TrainingFailed) and run.snapshot is not None:
            restore_best()
            exc.args = (f"{exc.args[0]}; kept the weights of step {run.best['step']} "
                        f"(validation {run.best['val_psnr']:.2f} dB)",)
        exc.run = run
        raise
    finally:
        be.release()             # the training's cached memory, before evaluating and writing
    last = run.state.history["val_psnr"][-1] if val is not None else None
    if cfg.keep_best and run.best and last is not None and run.best["step"] != run.state.step \
            and keeps_best(run.best["val_psnr"], last, cfg.keep_best_margin):
        restore_best()
        run.notes.append(f"kept the checkpoint of step {run.best['step']} (validation {run.best['val_psnr']:.2f} dB; "
                         f"the last step, {run.state.step}, had {last:.2f} dB)")
    return run


def settle_scene(recipe: Recipe, dataset: Dataset) -> tuple[float, float, float]:
    """Settle the recipe's scene for ``dataset`` (``auto``: :func:`~mitnerf.render.space.pick_scene`) and the frame of
    a forward-facing or unbounded one (kept when the recipe has it: a resumed run); returns the backend's ``bound,
    near, far``: the dataset's for an object, the frame's otherwise."""
    r = recipe.model.render
    if r.scene == "auto":
        r.scene = pick_scene(dataset)[0]
    if r.scene == "object":
        return dataset.bound, dataset.near, dataset.far
    if dataset.dim != 3:
        raise ConfigError(f"--scene-type {r.scene} needs 3D data; 2D data is an object in a box (--scene-type object)")
    if recipe.train.solid_weight > 0 and any(s.depth is not None for s in dataset.splits.values()):
        raise ConfigError(f"the solid loss needs an object in a box, not a {r.scene} scene: pass --solid-weight 0 "
                          "or --scene-type object")
    r.frame = r.frame or scene_frame(dataset, r.scene)
    return r.frame["bound"], r.frame["near"], r.frame["far"]


def keeps_best(best: float, last: float, margin: float) -> bool:
    """Whether a run ends with its best validation's weights (PSNR ``best``) rather than its last ones (``last``):
    only when the best is more than ``margin`` dB ahead (:attr:`~mitnerf.train.config.TrainConfig.keep_best_margin`)."""
    return best > last + margin


def fit_and_evaluate(dataset: Dataset, recipe: Recipe, backend: str = "drjit", split: str = "test",
                     geometry_metrics: bool = True, progress: bool = False) -> tuple[Run, RunRecord]:
    """Fit and evaluate, never raising for a run that fails: a NaN or a collapse comes back
    as the record's status (with the reason), evaluated on the weights that were kept; ``progress``: the training's
    progress bar."""
    try:
        run = fit(dataset, recipe, backend, progress=progress)
        return run, run.record(dataset, split, geometry_metrics=geometry_metrics)
    except TrainingFailed as exc:
        rec = exc.run.record(dataset, split, geometry_metrics=geometry_metrics)
        rec.status, rec.reason = exc.status, str(exc)
        return exc.run, rec
