"""The fuzz suite's rule and its valid inputs.

The rule (:func:`refused`): a bad input to the command line ends in ONE line on stderr that
starts with ``mitnerf: error:``, exit status 2, no traceback, and nothing written (no output
folder, no temporary leftovers, the inputs untouched). Every case goes through the real entry
point, ``mitnerf.cli.main``, in-process, and is recorded in :data:`CASES` (the counts are
printed at the end of the pytest run).

The valid inputs: tiny datasets in every format mitnerf reads, written by mitnerf's own
writers, and the two foreign layouts it reads (the NeRF2D add-on's, instant-ngp's).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import struct
import sys
import tempfile
import warnings
import zipfile
import zlib
from collections import defaultdict
from pathlib import Path

import numpy as np
from hypothesis import note, settings

from mitnerf.cli import main
from mitnerf.data.formats.common import BYTES_PER_PIXEL, MAX_SIDE


ROOT = Path(__file__).resolve().parents[2]
"""The repository (the subprocess cases run ``python -m mitnerf`` from it)."""
CASES: dict[str, set[str]] = defaultdict(set)
"""category -> the distinct cases tried (descriptions), reported at the end of the run."""

NAN, INF = float("nan"), float("inf")


def examples(weight: float) -> settings:
    """This test's share of the profile's ``max_examples``."""
    return settings(max_examples=max(1, round(weight * settings.default.max_examples)))


# --------------------------------------------------------------------------------- the rule

def run_main(argv) -> tuple[int, str, str, list]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rc = main([str(a) for a in argv])
        except SystemExit as exc:
            rc = exc.code
        except Exception as exc:  # noqa: BLE001 - a traceback is what the rule forbids
            raise AssertionError(f"traceback: {type(exc).__name__}: {exc}") from exc
    shown = [w for w in caught if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning,
                                                               ImportWarning, ResourceWarning))]
    return rc, out.getvalue(), err.getvalue(), shown


def snapshot(root: Path) -> dict:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) if p.is_file() else "dir"
            for p in sorted(root.rglob("*"))}


def say(text: str) -> None:
    """Hypothesis's ``note`` (printed with a failing example), outside ``@given`` too."""
    try:
        note(text)
    except Exception:  # noqa: BLE001 - InvalidArgument outside a Hypothesis test
        pass


def refused(category: str, desc: str, argv, root: Path, out: Path | None = None) -> str:
    """Run ``argv``; assert the rule; record the case. Returns the error line."""
    say(f"case: {desc}")
    if os.environ.get("FUZZ_TRACE"):
        print(f"fuzz case: {category}: {desc}", file=sys.__stderr__, flush=True)
    before = snapshot(root)
    rc, stdout, stderr, shown = run_main(argv)
    after = snapshot(root)
    lines = stderr.splitlines()
    say(f"exit {rc}; stderr {stderr!r}; stdout {stdout[-300:]!r}")
    assert rc == 2, f"{desc}: exit status {rc}, not 2 (stderr {stderr[-300:]!r}, stdout {stdout[-300:]!r})"
    assert len(lines) == 1 and lines[0].startswith("mitnerf: error: "), f"{desc}: stderr is not one line: {stderr!r}"
    assert "Traceback" not in stderr
    assert not shown, f"{desc}: warnings reach stderr: {[str(w.message) for w in shown]}"
    assert stdout == "", f"{desc}: printed {stdout!r} before refusing"
    assert after == before, f"{desc}: wrote or changed {sorted(set(after.items()) ^ set(before.items()))[:5]}"
    if out is not None:
        assert not out.exists(), f"{desc}: {out} was written"
    assert len(lines[0]) < 1000, f"{desc}: the message is {len(lines[0])} characters long"
    CASES[category].add(desc)
    if os.environ.get("FUZZ_TRACE"):
        print(f"  -> {lines[0]}", file=sys.__stderr__, flush=True)
    return lines[0]


@contextlib.contextmanager
def case_dir():
    with tempfile.TemporaryDirectory(prefix="fuzz-") as t:
        yield Path(t)


# ------------------------------------------------------------------------------ valid inputs

def png_header(width: int, height: int) -> bytes:
    """A PNG whose header says ``width x height`` RGBA, with no real pixels behind it."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * 16)) + chunk(b"IEND", b""))


def png(h: int, w: int, seed: int = 0) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    rgba = np.random.default_rng(seed).integers(0, 256, (h, w, 4), dtype=np.uint8)
    Image.fromarray(rgba, "RGBA").save(buf, format="PNG")
    return buf.getvalue()


def npz_bytes(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def npz_with_fake(arrays: dict, fake: dict) -> bytes:
    """An .npz holding ``arrays`` and, for each ``name: (shape, dtype)`` of ``fake``, only an
    .npy header that claims that shape (what a huge or truncated array looks like)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for k, a in arrays.items():
            b = io.BytesIO()
            np.save(b, a)
            z.writestr(f"{k}.npy", b.getvalue())
        for k, (shape, dtype) in fake.items():
            b = io.BytesIO()
            np.lib.format.write_array_header_1_0(b, {"descr": np.dtype(dtype).str, "fortran_order": False,
                                                     "shape": tuple(shape)})
            z.writestr(f"{k}.npy", b.getvalue())
    return buf.getvalue()


def mem_total() -> int:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def write_addon(ds, root: Path) -> None:
    """A folder as the original NeRF2D add-on writes it: focal as int, RGBA PNGs, npz files
    with depth_map and intrinsic_mat only, camera_info.json, no mitnerf.json."""
    import imageio.v3 as iio

    from mitnerf.data.color import to_uint8

    for name in ("train", "val", "test"):
        split = ds[name]
        d = root / name
        d.mkdir(parents=True)
        f = int(round(split.cameras.focal))
        H = split.cameras.height
        frames = [{"transform_matrix": p.tolist()} for p in split.cameras.poses]
        (d / "transforms.json").write_text(json.dumps({"focal": f, "frames": frames}))
        (d / "camera_info.json").write_text(json.dumps({"img_res_x": 1, "img_res_y": H}))
        for i in range(len(split)):
            rgba = np.concatenate([split.color[i], np.ones_like(split.alpha[i])[..., None]], -1)
            iio.imwrite(d / f"cam-{i}.png", to_uint8(rgba))
            depth = np.where(split.mask[i], split.depth[i], -1.0)
            K = np.array([[f, 0, 0], [0, f, (H - 1) / 2], [0, 0, 1]], float)
            np.savez(d / f"cam-{i}.npz", depth_map=depth, intrinsic_mat=K)


def write_ngp(blender: Path, root: Path) -> None:
    """An instant-ngp style transforms.json: camera_angle_x only, file paths without extension."""
    (root / "images").mkdir(parents=True)
    frames, angle = [], None
    for s in ("train", "val", "test"):
        header = json.loads((blender / f"transforms_{s}.json").read_text())
        angle = header["camera_angle_x"]
        for f in header["frames"]:
            name = f"r_{len(frames)}"
            shutil.copy(blender / (f["file_path"][2:] + ".png"), root / "images" / f"{name}.png")
            frames.append({"file_path": f"images/{name}", "transform_matrix": f["transform_matrix"]})
    (root / "transforms.json").write_text(json.dumps({"camera_angle_x": angle, "aabb_scale": 4, "frames": frames},
                                                     indent=1))


class Inputs(dict):
    """The valid inputs by name (a short repr: Hypothesis prints it with every failure)."""

    def __repr__(self):
        return "<valid inputs>"


def ring_points(k: int, r: float = 0.8) -> list:
    a = np.linspace(0, 2 * np.pi, k, endpoint=False)
    pts = np.c_[r * np.cos(a), r * np.sin(a)].tolist()
    return pts + pts[:1]


XML = """<scene version="3.0.0">
    <bsdf type="diffuse" id="mat"><rgb name="reflectance" value="0.5"/></bsdf>
    <shape type="sphere"><float name="radius" value="0.5"/><ref id="mat"/></shape>
    <shape type="ply"><string name="filename" value="{ply}"/><ref id="mat"/></shape>
    <emitter type="point"><point name="position" x="0" y="0" z="5"/><rgb name="intensity" value="20"/></emitter>
</scene>
"""
