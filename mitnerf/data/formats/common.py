"""Shared reading helpers: JSON, images and our provenance file, with errors that say the fix."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import MitnerfError

META = "mitnerf.json"


def read_json(path: Path) -> dict:
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise MitnerfError(f"{path} does not exist; point at a dataset folder written by `mitnerf dataset`") from None
    except OSError as exc:
        raise MitnerfError(f"cannot read {path}: {exc.strerror}; check the path and its permissions") from None
    except json.JSONDecodeError as exc:
        raise MitnerfError(f"{path} is not valid JSON ({exc.msg} at line {exc.lineno}); fix or regenerate it") from None


def read_image(path: Path) -> np.ndarray:
    """An 8- or 16-bit image as float32 in [0, 1], ``[H, W]`` or ``[H, W, C]``."""
    import imageio.v3 as iio

    try:
        img = iio.imread(path)
    except FileNotFoundError:
        raise MitnerfError(f"image {path} is missing; every frame needs its image") from None
    except Exception as exc:  # imageio raises many types for corrupt files
        raise MitnerfError(f"cannot read image {path} ({type(exc).__name__}); replace the file") from None
    scale = 65535.0 if img.dtype == np.uint16 else 255.0 if img.dtype == np.uint8 else 1.0
    return img.astype(np.float32) / scale


def write_meta(folder: Path, dataset, fmt: str) -> None:
    meta = {**dataset.meta, "format": fmt, "near": dataset.near, "far": dataset.far,
            "splits": {k: len(v) for k, v in dataset.splits.items()}}
    (folder / META).write_text(json.dumps(meta, indent=1))


def read_meta(folder: Path) -> dict:
    path = Path(folder) / META
    return read_json(path) if path.exists() else {}
