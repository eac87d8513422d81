"""Checkpoints you can trust (the ``--out`` folder of ``mitnerf fit``); never pickle::

    manifest.json   {"format": "mitnerf-checkpoint", "version": 2, "field", "dim", "backend",
                     "recipe", "bound", "near", "far", "dataset", "loop", "best", "metrics",
                     "arrays": {"<file>.npz": {"<name>": {"shape", "dtype", "sha256"}}}}
    weights.npz     the model (canonical names, both engines read it) and the occupancy grid
    state.npz       Adam's moments (engine-specific names), the best weights and a mined run's error map: for
                    --resume
    history.json    the loss and validation curves
    metrics.json    the evaluation (:func:`write_fit`), beside the figures: curves, test views, density

Loading checks the format and version (a newer one is refused), the field and dimension the caller needs,
and each array's presence, shape, dtype, SHA-256 and finiteness; a failure raises one ``CheckpointError``."""

from __future__ import annotations

import hashlib
import json
import math
import zipfile
from pathlib import Path

import numpy as np

from .._io import atomic_write_text, json_text
from ..data.dataset import Dataset
from ..errors import CheckpointError, MitnerfError
from ..viz.views import plot_curves, save_density, save_renders
from .auto import final_params
from .engines import make_backend
from .evaluate import RunRecord, peak_memory
from .fit import Run
from .loop import LoopState, new_history
from .recipes import Recipe

FORMAT = "mitnerf-checkpoint"
VERSION = 2


def _sha(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).reshape(-1).view(np.uint8)).hexdigest()      # no copy


def _write_npz(path: Path, arrays: dict) -> dict:
    """Write ``arrays`` as numpy's ``.npz`` (stored, not compressed) to ``path``, one array at a time, so the archive
    is never whole in memory; returns each array's shape, dtype and SHA-256 (the manifest's ``arrays`` entry)."""
    meta = {}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
        for name, value in arrays.items():
            a = np.ascontiguousarray(value)
            with z.open(f"{name}.npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, a, allow_pickle=False)
            meta[name] = {"shape": list(a.shape), "dtype": str(a.dtype), "sha256": _sha(a)}
    return meta


def save_checkpoint(run: Run, folder: str | Path, metrics: dict | None = None) -> Path:
    """Write ``run``'s checkpoint into ``folder`` (a staged output folder; files are atomic). Where ``metrics`` holds
    a ``peak_memory``, it is raised to the process's peak once the arrays are written (writing them holds a copy of
    the weights), in the dict the caller passed as well."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    be = run.backend
    arrays = {"weights.npz": _write_npz(folder / "weights.npz", be.get_weights())}
    state = {f"optimizer.{k}": v for k, v in be.optimizer_state().items()}
    state.update({f"mining.{k}": v for k, v in be.sampling_state().items()})
    if run.snapshot is not None:
        state.update({f"best.{k}": v for k, v in run.snapshot.items()})
    arrays["state.npz"] = _write_npz(folder / "state.npz", state)
    del state
    if metrics is not None and "peak_memory" in metrics:
        metrics["peak_memory"] = max(peak_memory(), metrics["peak_memory"])      # a NaN (no record) gives way
    manifest = {"format": FORMAT, "version": VERSION, "field": run.recipe.model.field, "dim": be.dim,
                "backend": be.name, "recipe": run.recipe.to_dict(), "bound": be.bound, "near": be.near,
                "far": be.far, "dataset": run.dataset_meta,
                "loop": {"step": run.state.step, "train_time": run.state.train_time, "step_reached": be.step_reached},
                "best": run.best,
                "metrics": metrics or {}, "arrays": arrays}
    atomic_write_text(folder / "history.json", json_text(run.state.history, indent=None))
    atomic_write_text(folder / "manifest.json", json_text(manifest))
    return folder


def write_fit(run: Run, folder: Path, record: RunRecord | None = None, dataset: Dataset | None = None) -> Path:
    """Write ``run`` into ``folder``; with ``record`` and ``dataset`` also the metrics and figures."""
    metrics = record.row() if record is not None else {"interrupted_at": run.state.step}
    save_checkpoint(run, folder, metrics)
    if record is not None:
        record.peak_memory = metrics["peak_memory"]         # the checkpoint's writing counted
    atomic_write_text(folder / "metrics.json", json_text({**metrics, "notes": run.notes}))
    if record is not None and dataset is not None and record.renders is not None:
        title = f"{dataset.name}, {run.recipe.name} ({run.backend.name})"
        plot_curves(run.state.history, folder / "curves.png", title)
        save_renders(record.renders, dataset["test"].subset(record.renders["views"]),
                     run.recipe.model.render.render_background(), folder, dataset.near, dataset.far,
                     title=title)
        save_density(run.backend.density, run.bound, dataset.dim, folder / "density.png",
                     dataset.meta.get("polygon"), title=f"density: {title}")
    return folder


def checkpoint_bytes(recipe: Recipe, dim: int) -> int:
    """About what ``mitnerf fit --out`` writes for ``recipe``: the weights, Adam's two moments and the best
    weights (float32), and room for the figures."""
    m = recipe.model
    try:
        params = final_params(m.field, m.field_args, dim)
    except (MitnerfError, TypeError):           # a field sized by its data (pixelNeRF): the figures only
        params = 0
    return 16 * params + (32 << 20)


def read_manifest(path: str | Path) -> dict:
    path = Path(path)
    f = path / "manifest.json"
    if not f.is_file():
        old = " (it looks like a checkpoint of mitnerf < 0.2: refit it)" if (path / "config.json").exists() else ""
        raise CheckpointError(f"{path} is not a mitnerf checkpoint: it has no manifest.json{old}; "
                              "pass the --out folder of `mitnerf fit`")
    try:
        m = json.loads(f.read_text())
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise CheckpointError(f"{f} is not valid JSON ({type(exc).__name__}); the checkpoint is corrupt: "
                              "refit it or restore a copy") from None
    if not isinstance(m, dict) or m.get("format") != FORMAT:
        raise CheckpointError(f"{f} is not a mitnerf checkpoint manifest; pass the --out folder of `mitnerf fit`")
    version = m.get("version")
    if type(version) is not int:                # JSON: not a bool, a float or a string
        raise CheckpointError(f"{f} has no valid format version; the checkpoint was edited: refit it")
    if version > VERSION:
        raise CheckpointError(f"{path} was written by a newer mitnerf (checkpoint format {version}, this one reads "
                              f"up to {VERSION}); upgrade mitnerf")
    if version < VERSION:
        raise CheckpointError(f"{path} has checkpoint format {version}, which this mitnerf no longer reads; refit it")
    try:
        assert m["dim"] in (2, 3) and isinstance(m["field"], str) and isinstance(m["arrays"], dict)
        assert all(isinstance(v, dict) and all(isinstance(e, dict) for e in v.values()) for v in m["arrays"].values())
        assert all(type(m[k]) in (int, float) and math.isfinite(m[k]) for k in ("bound", "near", "far"))
        assert m["bound"] > 0 and 0 <= m["near"] < m["far"]
        r = m["recipe"] = Recipe.from_dict(m["recipe"])
        assert r.model.field == m["field"] and r.dim == m["dim"] and isinstance(r.name, str)
        step, train_time = m["loop"]["step"], m["loop"]["train_time"]     # a list or string: TypeError
        assert type(step) is int and step >= 0 and type(train_time) in (int, float)
        assert math.isfinite(train_time) and train_time >= 0
        reached = m["loop"].setdefault("step_reached", step - 1 if step > 0 else None)   # older checkpoints
        assert reached is None or (type(reached) is int and 0 <= reached < max(step, 1))
        assert all(isinstance(m.get(key, {}), dict) for key in ("dataset", "best", "metrics"))
        assert all(isinstance(m.get("dataset", {}).get(key, ""), str) for key in ("path", "mesh", "texture", "scene"))
    except (AssertionError, KeyError, TypeError, ValueError, AttributeError):
        raise CheckpointError(f"{f} is incomplete or was edited (a missing or malformed entry); refit it") from None
    try:
        m["recipe"].validate()
    except (MitnerfError, TypeError, ValueError) as exc:
        raise CheckpointError(f"{f} holds a recipe that cannot run ({exc}); the checkpoint was edited: "
                              "refit it") from None
    return m


def read_arrays(path: Path, name: str, listed: dict) -> dict[str, np.ndarray]:
    """The arrays of ``path/name``, checked against the manifest's entry ``listed``."""
    f = path / name
    try:
        with np.load(f, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise CheckpointError(f"{f} is missing; the checkpoint is incomplete: refit it") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise CheckpointError(f"{f} is truncated or corrupt ({type(exc).__name__}); refit it or restore a "
                              "copy") from None
    if set(arrays) != set(listed):
        diff = sorted(set(arrays) ^ set(listed))
        raise CheckpointError(f"{f} does not hold the arrays its manifest lists (differ: {', '.join(diff[:3])}); "
                              "the checkpoint was edited: refit it")
    for k, a in arrays.items():
        meta = listed[k]
        if not isinstance(meta, dict) or list(a.shape) != meta.get("shape") or str(a.dtype) != meta.get("dtype"):
            raise CheckpointError(f"{f}: array {k!r} has shape {list(a.shape)} {a.dtype}, the manifest says "
                                  f"{meta}; the checkpoint was edited: refit it")
        if _sha(a) != meta.get("sha256"):
            raise CheckpointError(f"{f}: array {k!r} does not match its recorded SHA-256; the file changed after "
                                  "it was written: refit it or restore a copy")
        if a.dtype.kind not in "fiu":
            raise CheckpointError(f"{f}: array {k!r} holds {a.dtype} values, not numbers; the checkpoint was "
                                  "edited: refit it")
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            raise CheckpointError(f"{f}: array {k!r} contains NaN or infinity; this model cannot render: refit it")
    return arrays


def load_checkpoint(path: str | Path, backend: str | None = None, *, field: str | None = None,
                    dim: int | None = None, need: str | None = None) -> tuple[Run, dict]:
    """Rebuild a checkpoint's model (in its own engine unless ``backend`` says otherwise); ``field`` / ``dim``: what
    the caller (``need``, named in errors) needs. Returns the :class:`Run` and the resume state (optimizer, loop)."""
    path = Path(path)
    m = read_manifest(path)
    who = need or "this command"
    if dim is not None and m["dim"] != dim:
        raise CheckpointError(f"{path} holds a {m['dim']}D {m['field']} field; {who} needs a {dim}D one")
    if field is not None and m["field"] != field:
        raise CheckpointError(f"{path} holds a {m['field']} field; {who} needs a {field} field")
    weights = read_arrays(path, "weights.npz", m["arrays"].get("weights.npz", {}))
    state = read_arrays(path, "state.npz", m["arrays"].get("state.npz", {}))
    recipe: Recipe = m["recipe"]
    recipe.train.progress = False
    be = make_backend(backend or m["backend"], recipe.model, recipe.train, m["dim"], m["bound"], m["near"], m["far"])
    try:
        be.set_weights(weights)
    except (MitnerfError, KeyError, ValueError, RuntimeError) as exc:
        raise CheckpointError(f"{path}: the weights do not fit the model its manifest describes ({exc}); "
                              "the checkpoint was edited: refit it") from None
    shapes = {k: np.shape(v) for k, v in be.get_weights().items()}
    unknown = sorted(set(weights) - set(shapes))
    if unknown:
        raise CheckpointError(f"{path}: weights.npz holds arrays that the model its manifest describes does not "
                              f"have ({', '.join(unknown[:3])}); the checkpoint was edited: refit it")
    best = {k[5:]: v for k, v in state.items() if k.startswith("best.")}
    optim = {k[10:]: v for k, v in state.items() if k.startswith("optimizer.")}
    mining = {k[7:]: v for k, v in state.items() if k.startswith("mining.")}
    other = sorted(k for k in state if not k.startswith(("best.", "optimizer.", "mining.")))
    if other:
        raise CheckpointError(f"{path}: state.npz holds arrays that are neither best weights, optimizer state nor "
                              f"the error map ({', '.join(other[:3])}); the checkpoint was edited: refit it")
    if best and (set(best) != set(weights) or any(np.shape(best[k]) != shapes[k] for k in weights)):
        raise CheckpointError(f"{path}: state.npz holds best weights that do not fit the model its manifest "
                              "describes; the checkpoint was edited: refit it")
    moments = {k[:-2]: v for k, v in optim.items() if k.endswith(".m")}     # names are engine-specific
    if optim and (len(optim) != 3 * len(moments) or sum(v.size for v in moments.values()) != be.n_params() or not all(
            f"{k}.v" in optim and optim[f"{k}.v"].shape == v.shape and f"{k}.t" in optim and optim[f"{k}.t"].size == 1
            for k, v in moments.items())):
        raise CheckpointError(f"{path}: state.npz holds optimizer state that does not fit the model its manifest "
                              "describes (Adam keeps two moments per parameter); the checkpoint was edited: refit it")
    try:
        history = {**new_history(), **{k: [math.nan if v is None else v for v in vs] if isinstance(vs, list) else vs
                                       for k, vs in json.loads((path / "history.json").read_text()).items()}}
    except (OSError, ValueError, TypeError):                 # TypeError: not a JSON object
        history = new_history()
    loop = LoopState(int(m["loop"]["step"]), float(m["loop"]["train_time"]), history)
    be.step_reached = m["loop"]["step_reached"]         # a step-dependent schedule renders as it was trained
    run = Run(be, recipe, dict(m.get("dataset") or {}), loop, dict(m.get("best") or {}))
    return run, {"weights": weights, "optimizer": optim, "state": loop, "step_reached": be.step_reached,
                 "best": run.best, "best_weights": best or None, "mining": mining,
                 "backend": m["backend"], "metrics": m.get("metrics", {})}
