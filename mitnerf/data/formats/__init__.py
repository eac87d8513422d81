"""Dataset file formats: NeRF2D (2D, ours and the original add-on's), Blender, nerfstudio
and instant-ngp ``transforms.json`` (3D; nerfstudio also 2D), tiny-NeRF (3D, one file).

:func:`load_dataset` detects the format and checks every input (:mod:`.common`);
:func:`save_dataset` writes NeRF2D for 2D and Blender for 3D unless told otherwise,
into a folder that follows mitnerf's output rules (:class:`mitnerf._io.Output`).
"""

from __future__ import annotations

from pathlib import Path

from ..._io import Output, atomic_write_bytes
from ...errors import DataError, OutputError
from ..dataset import Dataset
from .nerf2d import read_nerf2d, write_nerf2d
from .tiny_nerf import read_tiny_nerf, tiny_nerf_bytes
from .transforms import read_transforms, write_blender, write_nerfstudio

WRITERS = {"nerf2d": write_nerf2d, "blender": write_blender, "nerfstudio": write_nerfstudio}
FORMATS = (*WRITERS, "tiny_nerf")


def detect_format(path: str | Path) -> str:
    path = Path(path)
    if path.is_file() and path.suffix == ".npz":
        return "tiny_nerf"
    if not path.exists():
        raise DataError(f"dataset {path} does not exist; create it with `mitnerf dataset --out {path}`")
    if not path.is_dir():
        raise DataError(f"{path} is neither a dataset folder nor a tiny-NeRF .npz file")
    try:
        names = {p.name for p in path.iterdir()}
    except OSError as exc:
        raise DataError(f"cannot list dataset folder {path}: {exc.strerror}; check its permissions") from None
    if (path / "train" / "transforms.json").is_file():
        return "nerf2d"
    if "transforms_train.json" in names or "transforms.json" in names:
        return "transforms"
    raise DataError(f"{path} is not a dataset folder: it has no train/transforms.json (NeRF2D) and no "
                    "transforms_train.json or transforms.json (Blender/nerfstudio); "
                    "write one with `mitnerf dataset --out DIR`")


def load_dataset(path: str | Path) -> Dataset:
    """Read and check a dataset in any supported format; ``meta['path']`` records where from."""
    fmt = detect_format(path)
    ds = {"nerf2d": read_nerf2d, "transforms": read_transforms, "tiny_nerf": read_tiny_nerf}[fmt](path)
    ds.meta["path"] = str(Path(path).resolve())
    return ds


def check_output(out: str | Path, fmt: str, overwrite: bool = False) -> Output | None:
    """Apply the output rules to ``out`` now, before any work (a file is never replaced)."""
    if fmt not in FORMATS:
        raise DataError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    if fmt == "tiny_nerf":
        if Path(out).exists() or Path(out).is_symlink():
            raise OutputError(f"{out} exists; mitnerf never replaces a file: choose another file name")
        return None
    return Output(out, "dataset", overwrite)


def save_dataset(dataset: Dataset, out: str | Path, fmt: str | None = None, overwrite: bool = False) -> Path:
    """Write ``dataset`` in ``fmt``; a folder follows the output rules, a file is never replaced."""
    fmt = fmt or ("nerf2d" if dataset.dim == 2 else "blender")
    target = check_output(out, fmt, overwrite)
    if target is None:
        return atomic_write_bytes(Path(out), tiny_nerf_bytes(dataset))
    with target.staged() as tmp:
        WRITERS[fmt](dataset, tmp)
    return out


__all__ = ["FORMATS", "check_output", "load_dataset", "save_dataset", "detect_format", "read_nerf2d", "write_nerf2d",
           "read_transforms", "write_blender", "write_nerfstudio", "read_tiny_nerf", "tiny_nerf_bytes"]
