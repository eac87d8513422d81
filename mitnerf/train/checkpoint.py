"""Checkpoints: ``weights.npz`` (canonical, backend-independent names) + ``config.json``.

A checkpoint reloads into either backend and renders exactly what was saved
(``load_checkpoint(...).backend.render`` == the original's, bit for bit on Dr.Jit).
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from pathlib import Path

import numpy as np

from .._io import atomic_write_bytes
from ..errors import MitnerfError
from .config import ModelConfig, TrainConfig
from .trainer import Run, make_backend


def save_checkpoint(run: Run, out: str | Path, extra: dict | None = None) -> Path:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryFile() as f:
        np.savez(f, **run.backend.get_weights())
        f.seek(0)
        atomic_write_bytes(out / "weights.npz", f.read())
    be = run.backend
    config = {"model": run.model_cfg.to_dict(), "train": dataclasses.asdict(run.train_cfg),
              "backend": be.name, "dim": be.model.dim, "bound": run.bound, "near": be.near, "far": be.far,
              "dataset": run.dataset_meta, "steps": run.steps, "train_time": run.train_time, **(extra or {})}
    atomic_write_bytes(out / "config.json", json.dumps(config, indent=1, default=str).encode())
    return out


def load_checkpoint(path: str | Path, backend: str | None = None) -> Run:
    """Rebuild the model of a checkpoint folder (in its own backend unless told otherwise)."""
    path = Path(path)
    try:
        config = json.loads((path / "config.json").read_text())
        weights = dict(np.load(path / "weights.npz"))
    except FileNotFoundError:
        raise MitnerfError(f"{path} is not a checkpoint (config.json and weights.npz needed); "
                           "pass the --out folder of `mitnerf fit`") from None
    model_cfg = ModelConfig.from_dict(config["model"])
    train_cfg = TrainConfig(**{k: v for k, v in config["train"].items() if k in TrainConfig.__dataclass_fields__})
    train_cfg.progress = False
    be = make_backend(backend or config["backend"], model_cfg, config["dim"], config["bound"],
                      config["near"], config["far"], train_cfg)
    be.set_weights(weights)
    run = Run(be, model_cfg, train_cfg, config.get("dataset", {}), config["bound"])
    run.steps, run.train_time = config.get("steps", 0), config.get("train_time", 0.0)
    return run
