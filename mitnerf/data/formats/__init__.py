"""Dataset file formats: NeRF2D (2D), Blender/nerfstudio (3D), tiny-NeRF (3D, one file).

:func:`load_dataset` detects the format; :func:`save_dataset` picks NeRF2D for 2D and
Blender for 3D unless told otherwise.
"""

from __future__ import annotations

from pathlib import Path

from ...errors import MitnerfError
from ..dataset import Dataset
from .blender import read_blender, write_blender
from .nerf2d import read_nerf2d, write_nerf2d
from .tiny_nerf import read_tiny_nerf, write_tiny_nerf

WRITERS = {"nerf2d": write_nerf2d, "blender": write_blender, "tiny_nerf": write_tiny_nerf}


def detect_format(path: str | Path) -> str:
    path = Path(path)
    if path.is_file() and path.suffix == ".npz":
        return "tiny_nerf"
    if not path.exists():
        raise MitnerfError(f"dataset {path} does not exist; create it with `mitnerf dataset --out {path}`")
    if not path.is_dir():
        raise MitnerfError(f"{path} is neither a dataset folder nor a tiny-NeRF .npz file")
    try:
        names = {p.name for p in path.iterdir()}
    except OSError as exc:
        raise MitnerfError(f"cannot list dataset folder {path}: {exc.strerror}; check its permissions") from None
    if (path / "train" / "transforms.json").exists():
        return "nerf2d"
    if "transforms_train.json" in names or "transforms.json" in names:
        return "blender"
    raise MitnerfError(f"{path} is not a dataset folder: it has no train/transforms.json (NeRF2D) and no "
                       "transforms_train.json or transforms.json (Blender/nerfstudio); "
                       "write one with `mitnerf dataset --out DIR`")


def load_dataset(path: str | Path) -> Dataset:
    """Read a dataset in any supported format."""
    fmt = detect_format(path)
    return {"nerf2d": read_nerf2d, "blender": read_blender, "tiny_nerf": read_tiny_nerf}[fmt](path)


def save_dataset(dataset: Dataset, out: str | Path, fmt: str | None = None) -> Path:
    fmt = fmt or ("nerf2d" if dataset.dim == 2 else "blender")
    if fmt not in WRITERS:
        raise MitnerfError(f"unknown format {fmt!r}; choose one of {', '.join(WRITERS)}")
    return WRITERS[fmt](dataset, out)


__all__ = ["load_dataset", "save_dataset", "detect_format", "read_nerf2d", "write_nerf2d",
           "read_blender", "write_blender", "read_tiny_nerf", "write_tiny_nerf"]
