"""Hostile inputs, generated (Hypothesis): every bad input to the command line ends in ONE
line on stderr that starts with ``mitnerf: error:``, exit status 2, no traceback, and
nothing written (no output folder, no temporary leftovers, the inputs untouched).

Each case starts from a VALID tiny input written by mitnerf's own writers (datasets in
every format mitnerf reads, polygons, Mitsuba XML, checkpoints, command lines) and breaks
exactly one thing, chosen by Hypothesis; a breakage is built so that it can never be
accidentally valid (a valid case would train and write, and fail the test). Everything
goes through the real entry point, ``mitnerf.cli.main``, in-process; a few cases run
``python -m mitnerf`` in a subprocess to see the real stderr.

Profiles (``tests/conftest.py``): ``HYPOTHESIS_PROFILE=ci`` (default: derandomized, a
fixed number of examples, well under a minute) or ``local`` (many more examples). The
number of distinct cases tried is printed at the end of the pytest run; ``FUZZ_TRACE=1``
(with ``pytest -s``) prints every case and the line it ended in.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import shutil
import string
import struct
import subprocess
import sys
import tempfile
import warnings
import zipfile
import zlib
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

from mitnerf.cli import main
from mitnerf.data.formats import save_dataset

ROOT = Path(__file__).resolve().parents[1]
CASES: dict[str, set[str]] = defaultdict(set)
"""category -> the distinct cases tried (descriptions), reported at the end of the run."""

NAN, INF = float("nan"), float("inf")
MAX_SIDE = 16384


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


@pytest.fixture(scope="module")
def base():
    """Valid inputs, written once: datasets in every format, polygons, XML, checkpoints."""
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.scenes.gt_render import RenderSettings
    from mitnerf.scenes.ply import write_ply
    from mitnerf.scenes.registry import get_scene

    with tempfile.TemporaryDirectory(prefix="fuzz-base-") as t:
        root = Path(t)
        d2 = make_dataset(get_scene("square"), RigConfig(dim=2, n_train=3, n_val=2, n_test=2, resolution=16, seed=1),
                          RenderSettings(spp=4), progress=False)
        d3 = make_dataset(get_scene("vase"), RigConfig(dim=3, n_train=3, n_val=1, n_test=2, resolution=8, seed=1),
                          RenderSettings(spp=4), progress=False)
        p = Inputs(d2=d2, d3=d3, root=root)
        for name, ds, fmt in [("nerf2d", d2, "nerf2d"), ("blender", d3, "blender"), ("nerfstudio3", d3, "nerfstudio"),
                              ("nerfstudio2", d2, "nerfstudio")]:
            p[name] = save_dataset(ds, root / name, fmt)
        write_addon(d2, root / "addon")
        p["addon"] = root / "addon"
        write_ngp(root / "blender", root / "ngp")
        p["ngp"] = root / "ngp"
        p["tiny"] = save_dataset(d3, root / "tiny.npz", "tiny_nerf")
        v, f, _ = get_scene("square").polygon.prism()
        write_ply(root / "mesh.ply", v, f)
        p["ply"] = root / "mesh.ply"
        small = ["--iters", "2", "--field", "vanilla", "--width", "8", "--depth", "2", "--samples", "8", "--fine", "0",
                 "--pos-L", "2", "--dir-L", "1", "--batch", "64", "--no-figures"]
        for name, data in (("ckpt3", "blender"), ("ckpt2", "nerf2d")):
            rc, out, err, _ = run_main(["fit", "--data", p[data], "--out", root / name, *small])
            assert rc == 0, err
            p[name] = root / name
        yield p


def test_valid_inputs_in_unicode_paths_with_spaces_work(base):
    """The valid inputs the fuzzing starts from load and train, from and into folders whose
    names hold spaces and non-ASCII characters."""
    with case_dir() as t:
        data = t / "dätä set ü"
        shutil.copytree(base["nerf2d"], data)
        out = t / "öut – ✓ run"
        rc, stdout, err, _ = run_main(["fit", "--data", data, "--iters", "1", "--out", out, "--no-figures"])
        assert rc == 0 and err.count("error") == 0 and (out / "manifest.json").is_file(), err
        tiny = t / "tïny nerf ✓.npz"
        shutil.copy(base["tiny"], tiny)
        rc, stdout, err, _ = run_main(["fit", "--data", tiny, "--iters", "1", "--no-figures"])
        assert rc == 0, err
        (t / "szène ✓.xml").write_text(XML.format(ply=base["ply"]))
        (t / "öutline ✓.json").write_text(json.dumps({"name": "fuzz ✓", "points": ring_points(6)}))
        for flag, f in (("--scene", "szène ✓.xml"), ("--polygon", "öutline ✓.json")):
            rc, stdout, err, _ = run_main(["dataset", flag, t / f, "--out", t / f"dätä {flag}", "--views", "1",
                                           "--val", "0", "--test", "1", "--resolution", "4", "--spp", "1"])
            assert rc == 0, err
        rc, stdout, err, _ = run_main(["video", "--checkpoint", base["ckpt3"], "--out", t / "vïdeo ✓", "--frames",
                                       "2", "--resolution", "4", "--mesh-resolution", "8", "--chamfer-points", "10",
                                       "--level", "auto"])
        assert rc == 0, err
    from mitnerf.data.formats import load_dataset

    for name in ("nerf2d", "addon", "blender", "nerfstudio3", "nerfstudio2", "ngp", "tiny"):
        ds = load_dataset(base[name])
        assert {"train", "test"} <= set(ds.splits), name


def ring_points(k: int, r: float = 0.8) -> list:
    a = np.linspace(0, 2 * np.pi, k, endpoint=False)
    pts = np.c_[r * np.cos(a), r * np.sin(a)].tolist()
    return pts + pts[:1]


# --------------------------------------------------------------------------- value strategies

class Raw:
    """A JSON token written as is (``1e999``, ``NaN``): what a hand-edited file may hold."""

    def __init__(self, token: str):
        self.token = token

    def __repr__(self):
        return self.token


def dumps(obj) -> str:
    raws = []

    def default(o):
        if isinstance(o, Raw):
            raws.append(o.token)
            return f"@@RAW{len(raws) - 1}@@"
        raise TypeError(type(o).__name__)

    text = json.dumps(obj, indent=1, default=default)
    for i, tok in enumerate(raws):
        text = text.replace(f'"@@RAW{i}@@"', tok)
    return text


def show(v) -> str:
    try:
        return dumps(v)[:60]
    except (TypeError, ValueError):
        return repr(v)[:60]


def edit_json(path: Path, fn) -> None:
    obj = json.loads(path.read_text())
    fn(obj)
    path.write_text(dumps(obj))


WRONG_TYPE = st.one_of(st.text(max_size=6), st.booleans(), st.lists(st.integers(-3, 3), max_size=3),
                       st.dictionaries(st.sampled_from(["a", "x"]), st.integers(0, 2), max_size=1),
                       st.sampled_from(["1", "2.5", "1e3", "nan", "true"]))
WRONG_TYPE_OR_NULL = st.one_of(WRONG_TYPE, st.none())
NON_FINITE = st.one_of(st.sampled_from([NAN, INF, -INF]), st.sampled_from(["1e999", "-1e999", "NaN", "Infinity",
                                                                          "-Infinity"]).map(Raw))


def finite(lo: float, hi: float) -> st.SearchStrategy:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def away_from(centre: float, gap: float, spread: float = 1e6) -> st.SearchStrategy:
    return st.one_of(finite(centre - spread, centre - gap), finite(centre + gap, centre + spread))


def bad_focal(pixels: int, allow_null: bool) -> st.SearchStrategy:
    """Not a focal length for a view ``pixels`` wide (a field of view outside (0.05, 179) degrees)."""
    return st.one_of(WRONG_TYPE_OR_NULL if allow_null else WRONG_TYPE, NON_FINITE, finite(-1e300, 0.0),
                     finite(1e9, 1e300), finite(1e-300, pixels * 2e-4))


def bad_bytes(keep_json_objects_out: bool = True) -> st.SearchStrategy:
    """Bytes that are no image, no array and no JSON object."""
    def ok(b: bytes) -> bool:
        try:
            return not isinstance(json.loads(b), dict)
        except (ValueError, UnicodeDecodeError, RecursionError):
            return True
    return st.binary(max_size=64).map(lambda b: b"\x00\x00\x00\x00" + b).filter(ok)


def draw_file_damage(data, path: Path, what: str, may_go: bool = True) -> tuple[str, callable]:
    """Truncate, replace with junk, empty, delete or turn into a folder: ``path`` is unreadable.
    ``may_go``: whether a missing file is an error (a split's only optional file is not)."""
    size = path.stat().st_size
    kind = data.draw(st.sampled_from(["truncated", "junk", "empty", "folder"] + (["missing"] if may_go else [])),
                     label="damage")
    if kind == "truncated":
        cut = data.draw(st.integers(1, max(1, size - 1)), label="cut at")
        return f"{what} cut to {cut} of {size} bytes", lambda: path.write_bytes(path.read_bytes()[:cut])
    if kind == "junk":
        junk = data.draw(bad_bytes(), label="junk")
        return f"{what} replaced by {len(junk)} junk bytes {junk[4:12]!r}", lambda: path.write_bytes(junk)
    if kind == "empty":
        return f"{what} empty", lambda: path.write_bytes(b"")
    if kind == "missing":
        return f"{what} missing", path.unlink

    def folder():
        path.unlink()
        path.mkdir()
    return f"{what} is a folder", folder


def draw_json_damage(data, path: Path) -> tuple[str, callable]:
    """Malformed JSON: truncated, not an object, junk, empty, not UTF-8, nested too deeply."""
    text = path.read_text()
    kind = data.draw(st.sampled_from(["truncated", "not an object", "junk", "not utf-8", "deep"]), label="json")
    if kind == "truncated":
        cut = data.draw(st.integers(0, len(text) - 1), label="cut at")
        return f"cut to {cut} characters", lambda: path.write_text(text[:cut])
    if kind == "not an object":
        v = data.draw(st.one_of(st.lists(st.integers(), max_size=2), st.integers(), st.text(max_size=4), st.none(),
                                st.booleans()), label="value")
        return f"holds {show(v)}", lambda: path.write_text(json.dumps(v))
    if kind == "junk":
        junk = data.draw(bad_bytes(), label="junk")
        return f"junk {junk[4:12]!r}", lambda: path.write_bytes(junk)
    if kind == "not utf-8":
        return "UTF-16 text", lambda: path.write_bytes(text.encode("utf-16"))
    depth = data.draw(st.sampled_from([200, 5000, 100_000]), label="depth")
    return f"nested {depth} deep", lambda: path.write_text("[" * depth + "]" * depth)


# --------------------------------------------------------------------------------- poses

def draw_pose_damage(data, M: list) -> tuple[str, object]:
    """A camera-to-world matrix (3x3 in 2D, 4x4 in 3D) made unusable."""
    k = len(M) - 1
    A = np.array(M, float)
    kind = data.draw(st.sampled_from(["non-finite", "far", "scaled", "sheared", "rank-1", "mirrored", "last row",
                                      "wrong type", "entry type", "shape"]), label="pose damage")
    if kind == "non-finite":
        r, c = data.draw(st.integers(0, k), label="row"), data.draw(st.integers(0, k), label="col")
        v = data.draw(st.sampled_from([NAN, INF, -INF]), label="value")
        A[r, c] = v
        return f"entry [{r}][{c}] = {v}", A.tolist()
    if kind == "far":
        r = data.draw(st.integers(0, k - 1), label="row")
        v = data.draw(finite(1e7, 1e300), label="distance") * data.draw(st.sampled_from([1, -1]), label="sign")
        A[r, k] = v
        return f"translation [{r}] = {v:g}", A.tolist()
    R = A[:k, :k]
    if kind == "scaled":
        s = data.draw(st.one_of(finite(0.0, 0.98), finite(1.02, 1e6)), label="scale")
        A[:k, :k] = R * s
        return f"rotation scaled by {s:g}", A.tolist()
    if kind == "sheared":
        i, j = data.draw(st.permutations(range(k)), label="axes")[:2]
        t = data.draw(finite(0.01, 1e3), label="shear") * data.draw(st.sampled_from([1, -1]), label="sign")
        S = np.eye(k)
        S[i, j] = t
        A[:k, :k] = R @ S
        return f"rotation sheared [{i}][{j}] by {t:g}", A.tolist()
    if kind == "rank-1":
        j = data.draw(st.integers(0, k - 1), label="col")
        A[:k, :k] = np.outer(R[:, 0], np.eye(k)[j])
        return f"rotation of rank 1 (column {j})", A.tolist()
    if kind == "mirrored":
        j = data.draw(st.integers(0, k - 1), label="col")
        A[:k, j] *= -1
        return f"rotation mirrored (column {j} negated)", A.tolist()
    if kind == "last row":
        j = data.draw(st.integers(0, k), label="col")
        v = data.draw(away_from(1.0 if j == k else 0.0, 0.01), label="value")
        A[k, j] = v
        return f"last row [{j}] = {v:g}", A.tolist()
    if kind == "wrong type":
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.integers()), label="matrix")
        return f"matrix = {show(v)}", v
    if kind == "entry type":
        r, c = data.draw(st.integers(0, k), label="row"), data.draw(st.integers(0, k), label="col")
        v = data.draw(st.one_of(st.just(str(A[r, c])), WRONG_TYPE_OR_NULL), label="entry")
        out = A.tolist()
        out[r][c] = v
        return f"entry [{r}][{c}] = {show(v)}", out
    how = data.draw(st.sampled_from(["drop row", "drop column", "add row", "flat", "add column", "nested"]),
                    label="shape")
    rows = A.tolist()
    out = {"drop row": rows[:-1], "drop column": [r[:-1] for r in rows], "add row": rows + [rows[-1]],
           "flat": [v for r in rows for v in r], "add column": [r + [0.0] for r in rows],
           "nested": [[[v] for v in r] for r in rows]}[how]
    return f"shape: {how}", out


def draw_frames_damage(data, path: Path, count_matters: bool) -> tuple[str, callable]:
    """Damage to the ``frames`` list of a transforms.json; ``count_matters``: one frame more or
    less is an error (NeRF2D: one image per frame), not a smaller dataset (Blender, nerfstudio)."""
    frames = json.loads(path.read_text())["frames"]
    kinds = ["missing", "not a list", "empty", "not an object", "pose", "no pose"] + (["dropped", "duplicated"]
                                                                            if count_matters else [])
    kind = data.draw(st.sampled_from(kinds), label="frames damage")
    i = data.draw(st.integers(0, len(frames) - 1), label="frame")
    if kind == "missing":
        desc, edit = "no frames", lambda o: o.pop("frames")
    elif kind == "not a list":
        v = data.draw(st.one_of(st.text(max_size=4), st.integers(), st.none(), st.booleans(),
                                st.dictionaries(st.sampled_from(["0", "a"]), st.integers(), max_size=1)), label="v")
        desc, edit = f"frames = {show(v)}", lambda o: o.__setitem__("frames", v)
    elif kind == "empty":
        desc, edit = "frames = []", lambda o: o.__setitem__("frames", [])
    elif kind == "not an object":
        v = data.draw(st.one_of(st.integers(), st.text(max_size=4), st.none(), st.lists(st.integers(), max_size=2)),
                      label="v")
        desc, edit = f"frame {i} = {show(v)}", lambda o: o["frames"].__setitem__(i, v)
    elif kind == "no pose":
        desc, edit = f"frame {i} without transform_matrix", lambda o: o["frames"][i].pop("transform_matrix")
    elif kind == "dropped":
        desc, edit = f"frame {i} dropped (a view without a pose)", lambda o: o["frames"].pop(i)
    elif kind == "duplicated":
        desc, edit = f"frame {i} duplicated (a pose without a view)", lambda o: o["frames"].append(o["frames"][i])
    else:
        d, value = draw_pose_damage(data, frames[i]["transform_matrix"])
        desc, edit = f"frame {i} pose: {d}", lambda o: o["frames"][i].__setitem__("transform_matrix", value)
    return desc, lambda: edit_json(path, edit)


# ------------------------------------------------------------------------------ the readers

def fit_or_show(data, ds: Path, t: Path, need_test: bool = False):
    """The command that reads the dataset: ``fit`` (always, when the damage is a missing test
    split, which ``show`` accepts) or ``show`` (which writes into the dataset folder)."""
    out = t / "out"
    if need_test or data.draw(st.integers(0, 3), label="command") > 0:
        return ["fit", "--data", ds, "--iters", "1", "--out", out], out
    return ["show", ds], ds / "figures"


def check_reader(category: str, data, src: Path, damage, need_test: bool = False):
    with case_dir() as t:
        ds = t / src.name
        if src.is_dir():
            shutil.copytree(src, ds)
        else:
            shutil.copy(src, ds)
        desc, fn = damage(ds)
        fn()
        argv, out = fit_or_show(data, ds, t, need_test)
        line = refused(category, f"{src.name}: {desc}", argv, t, out)
    if any(w in desc for w in ("png header of", " views of ", "(header only)")):   # too large: say how large
        assert "GiB" in line or str(MAX_SIDE) in line, f"{desc}: {line}"
    return line


def image_damage(data, img: Path, shape: tuple, others_in_split: bool) -> tuple[str, callable]:
    """A view that cannot be read, or one that does not fit the others: ``shape`` is (H, W)."""
    kind = data.draw(st.sampled_from(["file", "other size", "too large"] if others_in_split
                                     else ["file", "too large"]), label="image damage")
    if kind == "file":
        return draw_file_damage(data, img, "png")
    if kind == "other size":
        H, W = shape
        if W == 1:
            h, w = data.draw(st.one_of(st.tuples(st.integers(2, 40).filter(lambda h: h != H), st.just(1)),
                                       st.tuples(st.just(H), st.integers(2, 3))), label="size")
        else:
            h, w = data.draw(st.tuples(st.integers(1, 12), st.integers(1, 12)).filter(lambda s: s != (H, W)),
                             label="size")
        return f"png of {h} x {w} among {H} x {W}", lambda: img.write_bytes(png(h, w))
    side = data.draw(st.integers(MAX_SIDE + 1, 2 ** 31 - 1), label="side")
    other = data.draw(st.integers(1, 64), label="other side")
    w, h = data.draw(st.sampled_from([(side, other), (other, side), (side, side)]), label="orientation")
    return f"png header of {w} x {h} pixels", lambda: img.write_bytes(png_header(w, h))


def npz_damage(data, path: Path, H: int, ours: bool) -> tuple[str, callable]:
    """A NeRF2D ``cam-i.npz`` that is corrupt or holds arrays that do not fit the view."""
    if data.draw(st.booleans(), label="file or content"):
        kind = data.draw(st.sampled_from(["truncated", "junk", "empty", "folder"]), label="damage")
        if kind == "truncated":
            size = path.stat().st_size
            cut = data.draw(st.integers(1, size - 1), label="cut at")
            return f"npz cut to {cut} of {size} bytes", lambda: path.write_bytes(path.read_bytes()[:cut])
        if kind == "junk":
            junk = data.draw(bad_bytes(), label="junk")
            return f"npz is {len(junk)} junk bytes", lambda: path.write_bytes(junk)
        if kind == "empty":
            return "npz empty", lambda: path.write_bytes(b"")

        def folder():
            path.unlink()
            path.mkdir()
        return "npz is a folder", folder
    keys = ["depth_map"] + (["mask", "rgb_linear", "alpha"] if ours else [])
    key = data.draw(st.sampled_from(keys), label="array")
    kind = data.draw(st.sampled_from(["size", "non-finite", "text", "pickled"]), label="array damage")
    if key == "mask" and kind == "non-finite":
        kind = "size"
    if key == "alpha" and kind == "size" and data.draw(st.booleans(), label="out of range"):
        kind = "range"
    per = 3 if key == "rgb_linear" else 1
    if kind == "size":
        n = data.draw(st.integers(0, 40).filter(lambda n: n != H), label="pixels")
        value, desc = np.zeros((n, per) if per > 1 else n, np.float32), f"{n} values"
    elif kind == "non-finite":
        v = data.draw(st.sampled_from([NAN, INF, -INF]), label="value")
        i = data.draw(st.integers(0, H - 1), label="pixel")
        value = None
        desc = f"{v} at pixel {i}"
    elif kind == "range":
        v = data.draw(st.one_of(finite(-1e30, -0.01), finite(1.01, 1e30)), label="alpha")
        value, desc = np.full((H, 1), v, np.float32), f"alpha {v:g}"
    elif kind == "text":
        value, desc = np.array(["x"] * H), "strings"
    else:
        value, desc = np.array([object()] * H, dtype=object), "pickled objects"

    def fn():
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        if kind == "non-finite":
            a = arrays[key].astype(np.float32).copy()
            a.reshape(H, -1)[i] = v
            arrays[key] = a
        else:
            arrays[key] = value
        path.write_bytes(npz_bytes(**arrays) if kind != "pickled" else _pickled_npz(arrays))
    return f"{path.name} {key}: {desc}", fn


def _pickled_npz(arrays: dict) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)           # object arrays are pickled (allow_pickle defaults to True when saving)
    return buf.getvalue()


def meta_damage(data, path: Path) -> tuple[str, callable]:
    """Our ``mitnerf.json``: bounds, outline, background, names."""
    if data.draw(st.integers(0, 4), label="meta file") == 0:
        return draw_json_damage(data, path)
    meta = json.loads(path.read_text())
    key = data.draw(st.sampled_from(["near", "far", "order", "polygon", "background", "scene", "mesh"]), label="key")
    if key in ("near", "far"):
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, NON_FINITE, finite(-1e300, -1e-9), finite(1.1e6, 1e300)),
                      label=key)
    elif key == "order":
        key, v = "near", meta["far"] + data.draw(finite(0, 100), label="beyond far")
    elif key == "polygon":
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.lists(st.tuples(finite(-1, 1), finite(-1, 1)).map(list),
                                                            max_size=2),
                                st.just([[0, 0], [1, NAN], [1, 1]]), st.just([[0, 0, 0], [1, 0, 0], [1, 1, 0]]),
                                st.just([["0", "0"], ["1", "0"], ["1", "1"]])),
                      label="polygon")
    elif key == "background":
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL.filter(lambda v: not (isinstance(v, list) and len(v) == 3
                                                                        and all(0 <= x <= 1 for x in v))),
                                st.tuples(finite(1.01, 1e9), finite(0, 1), finite(0, 1)).map(list),
                                st.just([0, 0, NAN]), st.just([0.5, -0.5, 0])), label="background")
    else:
        v = data.draw(st.one_of(st.integers(), st.booleans(), st.lists(st.integers(), max_size=2),
                                st.dictionaries(st.sampled_from(["a"]), st.integers(), max_size=1)), label=key)
    return f"mitnerf.json {key} = {show(v)}", lambda: edit_json(path, lambda m: m.__setitem__(key, v))


NERF2D_COUNTS = {"train": 3, "val": 2, "test": 2}


@examples(2.0)
@given(data=st.data())
def test_nerf2d_folders(base, data):
    """NeRF2D folders, ours and the original add-on's."""
    fmt = data.draw(st.sampled_from(["nerf2d", "addon"]), label="writer")
    ours = fmt == "nerf2d"
    split = data.draw(st.sampled_from(list(NERF2D_COUNTS)), label="split")
    n = NERF2D_COUNTS[split]
    what = data.draw(st.sampled_from(["json file", "focal", "frames", "image", "npz", "count", "test split"]
                                     + (["meta"] if ours else [])), label="what")

    def damage(ds: Path):
        d = ds / split
        tj = d / "transforms.json"
        if what == "json file":
            desc, fn = draw_json_damage(data, tj)
        elif what == "focal":
            if data.draw(st.booleans(), label="delete"):
                desc, fn = "no focal", lambda: edit_json(tj, lambda o: o.pop("focal"))
            else:
                v = data.draw(bad_focal(16, allow_null=True), label="focal")
                desc, fn = f"focal = {show(v)}", lambda: edit_json(tj, lambda o: o.__setitem__("focal", v))
        elif what == "frames":
            desc, fn = draw_frames_damage(data, tj, count_matters=True)
        elif what == "image":
            i = data.draw(st.integers(0, n - 1), label="view")
            desc, fn = image_damage(data, d / f"cam-{i}.png", (16, 1), others_in_split=True)
            desc = f"cam-{i}.png: {desc}"
        elif what == "npz":
            i = data.draw(st.integers(0, n - 1), label="view")
            desc, fn = npz_damage(data, d / f"cam-{i}.npz", 16, ours)
        elif what == "count":
            if data.draw(st.booleans(), label="extra"):
                extra = data.draw(st.integers(n, n + 3), label="index")
                desc, fn = f"an extra cam-{extra}.png", lambda: shutil.copy(d / "cam-0.png", d / f"cam-{extra}.png")
            else:
                i = data.draw(st.integers(0, n - 1), label="view")
                desc, fn = f"cam-{i}.png missing", (d / f"cam-{i}.png").unlink
        elif what == "test split":
            desc, fn = "no test split", lambda: shutil.rmtree(ds / "test")
        else:
            return meta_damage(data, ds / "mitnerf.json")
        return f"{split}: {desc}", fn

    check_reader("reader: NeRF2D (ours and the add-on's)", data, base[fmt], damage, need_test=what == "test split")


def header_damage(data, header: dict, W: int, H: int, has_fl: bool, has_angle: bool) -> tuple[str, str, object]:
    """A camera header entry of a transforms.json that is wrong: returns (key, desc, value)."""
    keys = ["camera_model", "distortion", "w", "h", "cx", "cy"]
    keys += ["fl_x", "fl_y"] if has_fl else []
    keys += ["camera_angle_x"] if has_angle else []
    key = data.draw(st.sampled_from(keys), label="header key")
    if key == "camera_model":
        v = data.draw(st.one_of(st.text(max_size=12).filter(
            lambda s: s.upper() not in ("PINHOLE", "SIMPLE_PINHOLE", "OPENCV", "RADIAL", "SIMPLE_RADIAL")),
            st.sampled_from(["OPENCV_FISHEYE", "EQUIRECTANGULAR", "FISHEYE"]), st.integers(), st.none(),
            st.booleans()), label="model")
    elif key == "distortion":
        key = data.draw(st.sampled_from(["k1", "k2", "k3", "k4", "p1", "p2"]), label="coefficient")
        v = data.draw(st.one_of(away_from(0.0, 1e-6, 10.0), WRONG_TYPE, NON_FINITE), label=key)
    elif key in ("w", "h"):
        size = W if key == "w" else H
        v = data.draw(st.one_of(WRONG_TYPE, NON_FINITE, st.integers(-10, 10 ** 6).filter(lambda x: x != size),
                                finite(-1e9, 1e9).filter(lambda x: x != size)), label=key)
    elif key in ("cx", "cy"):
        c = (W if key == "cx" else H) / 2
        v = data.draw(st.one_of(WRONG_TYPE, NON_FINITE, away_from(c, 0.6)), label=key)
    elif key in ("fl_x", "fl_y"):
        f = header["fl_x"]
        v = data.draw(st.one_of(WRONG_TYPE, NON_FINITE, finite(-1e300, 0.0), away_from(f, 0.01 * f, 1e300)),
                      label=key)
    else:
        a = header["camera_angle_x"]
        inconsistent = away_from(a, 0.01, 3.0).filter(lambda x: 0 < x < 3.14) if has_fl else st.nothing()
        v = data.draw(st.one_of(WRONG_TYPE, NON_FINITE, finite(-10, 0), finite(3.14, 1e300), inconsistent),
                      label=key)
    return key, f"{key} = {show(v)}", v


BLENDER_COUNTS = {"train": 3, "val": 1, "test": 2}


def array_file_damage(data, path: Path, shape: tuple, what: str, may_go: bool = True) -> tuple[str, callable]:
    """A float ``.npy`` of ``shape`` that is unreadable or holds the wrong thing."""
    kind = data.draw(st.sampled_from(["file", "shape", "non-finite", "dtype"] + (["negative"] if what == "depth"
                                                                               else ["alpha"])), label="npy damage")
    if kind == "file":
        return draw_file_damage(data, path, f"{what} npy", may_go)
    if kind == "shape":
        s = data.draw(st.lists(st.integers(0, 9), min_size=1, max_size=4).filter(
            lambda s: int(np.prod(s)) != int(np.prod(shape))), label="shape")
        return f"{what} npy of shape {s}", lambda: np.save(path, np.zeros(s, np.float32))
    if kind == "dtype":
        v = data.draw(st.sampled_from(["strings", "objects", "complex"]), label="dtype")
        arr = {"strings": np.full(shape, "x"), "objects": np.full(shape, None, dtype=object),
               "complex": np.zeros(shape, np.complex64)}[v]
        return f"{what} npy of {v}", lambda: np.save(path, arr, allow_pickle=True)
    idx = tuple(data.draw(st.integers(0, s - 1), label="index") for s in shape)
    if kind == "non-finite":
        v = data.draw(st.sampled_from([NAN, INF, -INF]), label="value")
    elif kind == "negative":
        v = data.draw(finite(-1e30, -1e-3), label="value")
    else:
        idx = idx[:-1] + (3,)
        v = data.draw(st.one_of(finite(-1e30, -0.01), finite(1.01, 1e30)), label="alpha")

    def fn():
        a = np.load(path).copy()
        a[idx] = v
        np.save(path, a)
    return f"{what} npy {v} at {list(idx)}", fn


@examples(1.5)
@given(data=st.data())
def test_blender_folders(base, data):
    split = data.draw(st.sampled_from(list(BLENDER_COUNTS)), label="split")
    n = BLENDER_COUNTS[split]
    what = data.draw(st.sampled_from(["json file", "header", "no focal", "frames", "frame", "image", "depth",
                                      "linear", "test split", "meta", "memory"]), label="what")

    def damage(ds: Path):
        tj = ds / f"transforms_{split}.json"
        header = json.loads(tj.read_text())
        i = data.draw(st.integers(0, n - 1), label="frame")
        if what == "json file":
            desc, fn = draw_json_damage(data, tj)
        elif what == "header":
            key, desc, v = header_damage(data, header, 8, 8, True, True)
            where = data.draw(st.sampled_from(["header", "frame"]), label="where") if key not in (
                "camera_model",) else "header"
            if where == "frame":
                desc = f"frame {i} {desc}"
                fn = lambda: edit_json(tj, lambda o: o["frames"][i].__setitem__(key, v))  # noqa: E731
            else:
                fn = lambda: edit_json(tj, lambda o: o.__setitem__(key, v))  # noqa: E731
        elif what == "no focal":
            desc, fn = "neither fl_x nor camera_angle_x", lambda: edit_json(
                tj, lambda o: [o.pop(k) for k in ("fl_x", "fl_y", "camera_angle_x")])
        elif what == "frames":
            desc, fn = draw_frames_damage(data, tj, count_matters=False)
        elif what == "frame":
            key = data.draw(st.sampled_from(["file_path", "depth_file_path"]), label="key")
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL.filter(lambda v: not isinstance(v, str)), st.just(""),
                                    st.text(string.ascii_letters, min_size=1, max_size=8).map(lambda s: f"nope/{s}"),
                                    st.just("__delete__") if key == "file_path" else st.nothing()), label=key)
            if v == "__delete__":
                desc, fn = f"frame {i} without {key}", lambda: edit_json(tj, lambda o: o["frames"][i].pop(key))
            else:
                desc, fn = f"frame {i} {key} = {show(v)}", lambda: edit_json(
                    tj, lambda o: o["frames"][i].__setitem__(key, v))
        elif what == "image":
            desc, fn = image_damage(data, ds / split / f"r_{i}.png", (8, 8), others_in_split=n > 1)
            desc = f"r_{i}.png: {desc}"
        elif what == "depth":
            desc, fn = array_file_damage(data, ds / split / f"r_{i}_depth.npy", (8, 8), "depth")
        elif what == "linear":
            desc, fn = array_file_damage(data, ds / split / f"r_{i}_linear.npy", (8, 8, 4), "linear", n > 1)
        elif what == "test split":
            return "no transforms_test.json", (ds / "transforms_test.json").unlink
        elif what == "meta":
            return meta_damage(data, ds / "mitnerf.json")
        else:
            return memory_damage(data, ds / "transforms_train.json", ds, "train/r_0.png")
        return f"{split}: {desc}", fn

    check_reader("reader: Blender", data, base["blender"], damage, need_test=what == "test split")


def memory_damage(data, tj: Path, ds: Path, image: str, lists: str | None = None):
    """Views so large, or so many, that they would not fit in the machine's memory (or a view
    larger than the per-side limit): refused before anything is decoded, with the estimate."""
    side = data.draw(st.sampled_from([MAX_SIDE, 12000, 20000]), label="side")
    per_view = side * side * 96
    n = max(1, math.ceil(2 * mem_total() / per_view)) + data.draw(st.integers(0, 3), label="more")

    def fn():
        (ds / image).write_bytes(png_header(side, side))

        def edit(o):
            frames = o["frames"]
            f0 = next(f for f in frames if f["file_path"].lstrip("./").startswith(image.rsplit(".", 1)[0]))
            f0 = {k: v for k, v in f0.items() if k in ("file_path", "transform_matrix")}
            others = [f for f in frames if lists and f["file_path"] not in o[lists]]   # the other splits' frames
            frames[:] = [dict(f0) for _ in range(n)] + others
            if lists:
                o[lists] = [f0["file_path"]]
            for k in ("w", "h"):
                o.pop(k, None)
            if "cx" in o:
                o["cx"] = o["cy"] = side / 2
        edit_json(tj, edit)
    return f"{n} views of {side} x {side} pixels", fn


NS_COUNTS = {"train": 3, "val": 1, "test": 2}


@examples(1.5)
@given(data=st.data())
def test_nerfstudio_folders(base, data):
    dim = data.draw(st.sampled_from([3, 2]), label="dim")
    counts = NS_COUNTS if dim == 3 else NERF2D_COUNTS
    H, W = (8, 8) if dim == 3 else (16, 1)
    split = data.draw(st.sampled_from(list(counts)), label="split")
    i = data.draw(st.integers(0, counts[split] - 1), label="frame")
    what = data.draw(st.sampled_from(["json file", "header", "frames", "frame", "image", "depth", "mask", "lists",
                                      "dim", "depth unit", "test split", "meta"] + (["memory"] if dim == 3 else [])),
                     label="what")
    stem = f"{split}_{i:04d}"
    index = sum(list(counts.values())[:list(counts).index(split)]) + i

    def damage(ds: Path):
        tj = ds / "transforms.json"
        header = json.loads(tj.read_text())
        if what == "json file":
            return draw_json_damage(data, tj)
        if what == "header":
            key, desc, v = header_damage(data, header, W, H, True, False)
            return desc, lambda: edit_json(tj, lambda o: o.__setitem__(key, v))
        if what == "frames":
            return draw_frames_damage(data, tj, count_matters=False)
        if what == "frame":
            key = data.draw(st.sampled_from(["file_path", "depth_file_path", "mask_path"]), label="key")
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL.filter(lambda v: not isinstance(v, str)), st.just(""),
                                    st.text(string.ascii_letters, min_size=1, max_size=8).map(lambda s: f"nope/{s}")),
                          label=key)
            if key == "file_path":      # keep the frame in its split's list
                def fn():
                    edit_json(tj, lambda o: (o["frames"][index].__setitem__(key, v),
                                             o[f"{split}_filenames"].__setitem__(i, v)))
                return f"frame {stem} file_path = {show(v)}", fn
            return f"frame {stem} {key} = {show(v)}", lambda: edit_json(
                tj, lambda o: o["frames"][index].__setitem__(key, v))
        if what == "image":
            desc, fn = image_damage(data, ds / "images" / f"{stem}.png", (H, W), others_in_split=counts[split] > 1)
            return f"{stem}.png: {desc}", fn
        if what == "depth":
            desc, fn = array_file_damage(data, ds / "depths" / f"{stem}.npy", (H, W), "depth")
            return desc, fn
        if what == "mask":
            mask = ds / "masks" / f"{stem}.png"
            if data.draw(st.booleans(), label="file or size"):
                return draw_file_damage(data, mask, "mask png")
            h, w = data.draw(st.tuples(st.integers(1, 20), st.integers(1, 3)).filter(lambda s: s != (H, W)),
                             label="size")
            return f"mask {stem} of {h} x {w}", lambda: mask.write_bytes(png(h, w))
        if what == "lists":
            key = data.draw(st.sampled_from(["train_filenames", "val_filenames", "test_filenames"]), label="list")
            v = data.draw(st.one_of(st.text(max_size=4), st.integers(), st.none(), st.booleans(),
                                    st.dictionaries(st.sampled_from(["a"]), st.integers(), max_size=1)), label=key)
            if key == "train_filenames" and data.draw(st.booleans(), label="empty"):
                v = data.draw(st.sampled_from([[], ["nope.png"], ["images/none.png", "x"]]), label=key)
            return f"{key} = {show(v)}", lambda: edit_json(tj, lambda o: o.__setitem__(key, v))
        if what == "dim":
            v = data.draw(st.one_of(st.integers().filter(lambda d: d not in (2, 3)), st.text(max_size=3), st.none(),
                                    st.lists(st.integers(), max_size=2), finite(-10, 10).filter(
                                        lambda d: d not in (2, 3)),
                                    st.just(2) if dim == 3 else st.nothing()), label="mitnerf_dim")
            return f"mitnerf_dim = {show(v)}", lambda: edit_json(tj, lambda o: o.__setitem__("mitnerf_dim", v))
        if what == "depth unit":
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.fixed_dictionaries({"kind": st.text(max_size=3).filter(
                lambda k: k != "z"), "unit": st.just(0.001)}), st.fixed_dictionaries(
                {"kind": st.just("z"), "unit": st.one_of(WRONG_TYPE_OR_NULL, NON_FINITE, finite(-1e9, 0))})),
                label="mitnerf_depth")
            return f"mitnerf_depth = {show(v)}", lambda: edit_json(tj, lambda o: o.__setitem__("mitnerf_depth", v))
        if what == "test split":
            return "test_filenames = []", lambda: edit_json(tj, lambda o: o.__setitem__("test_filenames", []))
        if what == "meta":
            return meta_damage(data, ds / "mitnerf.json")
        return memory_damage(data, tj, ds, "images/train_0000.png", lists="train_filenames")

    check_reader(f"reader: nerfstudio ({dim}D)", data, base[f"nerfstudio{dim}"], damage,
                 need_test=what == "test split")


@examples(0.75)
@given(data=st.data())
def test_instant_ngp_folders(base, data):
    """transforms.json of instant-ngp: camera_angle_x, file paths without extension, no split lists."""
    what = data.draw(st.sampled_from(["json file", "angle", "no angle", "frames", "file_path", "image"]),
                     label="what")
    i = data.draw(st.integers(0, 5), label="frame")

    def damage(ds: Path):
        tj = ds / "transforms.json"
        if what == "json file":
            return draw_json_damage(data, tj)
        if what == "angle":
            key, desc, v = header_damage(data, json.loads(tj.read_text()), 8, 8, False, True)
            return desc, lambda: edit_json(tj, lambda o: o.__setitem__(key, v))
        if what == "no angle":
            return "no camera_angle_x", lambda: edit_json(tj, lambda o: o.pop("camera_angle_x"))
        if what == "frames":
            return draw_frames_damage(data, tj, count_matters=False)
        if what == "file_path":
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL.filter(lambda v: not isinstance(v, str)), st.just(""),
                                    st.text(string.ascii_letters, min_size=1, max_size=8).map(lambda s: f"nope/{s}")),
                          label="file_path")
            return f"frame {i} file_path = {show(v)}", lambda: edit_json(
                tj, lambda o: o["frames"][i].__setitem__("file_path", v))
        desc, fn = image_damage(data, ds / "images" / f"r_{i}.png", (8, 8), others_in_split=i > 0)
        return f"r_{i}.png: {desc}", fn

    check_reader("reader: instant-ngp transforms.json", data, base["ngp"], damage)


@examples(1.25)
@given(data=st.data())
def test_tiny_nerf_files(base, data):
    """tiny_nerf_data.npz: images, poses, focal (and our n_train, n_val)."""
    with np.load(base["tiny"]) as z:
        arrays = {k: z[k] for k in z.files}
    n, H, W = arrays["images"].shape[:3]
    what = data.draw(st.sampled_from(["file", "missing key", "images", "poses", "focal", "n_train", "n_val", "few",
                                      "memory"]), label="what")

    def damage(path: Path):
        a = dict(arrays)
        if what == "file":
            return draw_file_damage(data, path, "npz")
        if what == "missing key":
            k = data.draw(st.sampled_from(["images", "poses", "focal"]), label="key")
            a.pop(k)
            desc = f"no {k}"
        elif what == "images":
            kind = data.draw(st.sampled_from(["ndim", "channels", "dtype", "non-finite", "count"]), label="damage")
            if kind == "ndim":
                a["images"] = a["images"].reshape(n, H * W, 3) if data.draw(st.booleans()) else a["images"][..., 0]
            elif kind == "channels":
                c = data.draw(st.sampled_from([1, 2, 5, 7]), label="channels")
                a["images"] = np.zeros((n, H, W, c), np.float32)
            elif kind == "dtype":
                t = data.draw(st.sampled_from(["U1", "bool", "complex64"]), label="dtype")
                a["images"] = np.zeros(a["images"].shape, t)
            elif kind == "non-finite":
                v = data.draw(st.sampled_from([NAN, INF, -INF]), label="value")
                img = a["images"].copy()
                img[data.draw(st.integers(0, n - 1)), data.draw(st.integers(0, H - 1)), 0, 0] = v
                a["images"] = img
            else:
                m = data.draw(st.integers(1, n + 3).filter(lambda m: m != n), label="images")
                a["images"] = np.resize(a["images"], (m, H, W, 3))
            desc = f"images: {kind}"
        elif what == "poses":
            if data.draw(st.booleans(), label="shape or values"):
                s = data.draw(st.sampled_from([(n, 3, 4), (n - 1, 4, 4), (n, 4), (n, 3, 3), (4, 4), (n + 1, 4, 4)]),
                              label="shape")
                a["poses"] = np.resize(a["poses"], s)
                desc = f"poses of shape {s}"
            else:
                j = data.draw(st.integers(0, n - 1), label="pose")
                d, value = draw_pose_damage(data, a["poses"][j].tolist())
                numeric = isinstance(value, list) and len(value) == 4 and all(
                    isinstance(r, list) and len(r) == 4 and all(isinstance(v, float) for v in r) for r in value)
                if not numeric:                   # an npz holds no mixed lists: the poses become text
                    arr = None
                else:
                    with np.errstate(over="ignore"):
                        arr = np.array(value, np.float32)
                if arr is None:
                    a["poses"] = np.array([str(value)] * n)
                    desc = f"poses as text ({d})"
                else:
                    poses = a["poses"].copy()
                    poses[j] = arr
                    a["poses"] = poses
                    desc = f"pose {j}: {d}"
        elif what == "focal":
            v = data.draw(st.one_of(bad_focal(W, allow_null=False).filter(lambda v: isinstance(v, (float, int))
                                                                          and not isinstance(v, bool)),
                                    st.sampled_from(["text", "bool", "pair", "empty"])), label="focal")
            special = {"text": np.array("5"), "bool": np.array(True), "pair": np.array([10.0, 10.0]),
                       "empty": np.zeros(0)}
            a["focal"] = special[v] if isinstance(v, str) else np.array(v, np.float64)
            desc = f"focal = {v}"
        elif what in ("n_train", "n_val"):
            lo, hi = (1, n - 1) if what == "n_train" else (0, n - int(a["n_train"]) - 1)
            v = data.draw(st.one_of(st.integers(-10, 10 ** 6).filter(lambda x: not lo <= x <= hi),
                                    finite(lo + 0.1, hi - 0.1).filter(lambda x: not float(x).is_integer()),
                                    st.sampled_from(["nan", "text", "empty", "bool"])), label=what)
            a[what] = {"nan": np.array(NAN), "text": np.array("2"), "empty": np.zeros(0, int),
                       "bool": np.array(True)}.get(v) if isinstance(v, str) else np.array(v)
            desc = f"{what} = {v}"
        elif what == "few":
            m = data.draw(st.integers(0, 2), label="frames")
            a = {"images": a["images"][:m], "poses": a["poses"][:m], "focal": a["focal"]}
            desc = f"{m} frames"
        else:
            side = data.draw(st.sampled_from([MAX_SIDE, 12000, 20000, 10 ** 6]), label="side")
            m = max(3, math.ceil(2 * mem_total() / (side * side * 96))) + data.draw(st.integers(0, 3))
            raw = npz_with_fake({k: v for k, v in a.items() if k not in ("images", "poses")} |
                                {"poses": np.resize(a["poses"], (m, 4, 4))},
                                {"images": ((m, side, side, 3), np.float32)})
            return f"{m} images of {side} x {side} (header only)", lambda: path.write_bytes(raw)
        return desc, lambda: path.write_bytes(npz_bytes(**a))

    check_reader("reader: tiny-NeRF npz", data, base["tiny"], damage)


# ----------------------------------------------------------------------------- polygon files

def ring(data, k: int) -> list:
    """A valid convex ring of ``k`` points (closed: the first point repeated)."""
    angles = sorted(data.draw(st.lists(finite(0, 2 * math.pi - 1e-3), min_size=k, max_size=k,
                                       unique_by=lambda a: round(a, 2)), label="angles"))
    angles = np.linspace(0, 2 * np.pi, k, endpoint=False) if np.diff(angles).min(initial=1) < 0.05 else angles
    r = data.draw(finite(0.3, 1.5), label="radius")
    pts = [[r * math.cos(a), r * math.sin(a)] for a in angles]
    return pts + [pts[0]]


@examples(1.25)
@given(data=st.data())
def test_polygon_files(base, data):
    kind = data.draw(st.sampled_from(["open", "self-intersecting", "few points", "non-finite", "strings", "nested",
                                      "repeated vertex", "collinear", "json", "not points", "name", "too many"]),
                     label="kind")
    k = data.draw(st.integers(4, 9), label="points")
    pts = ring(data, k)
    wrap = data.draw(st.booleans(), label="as object")
    name = None
    if kind == "open":
        pts = pts[:-1]
        desc = f"open ring of {k}"
    elif kind == "self-intersecting":
        i = data.draw(st.integers(0, k - 2), label="swap")
        pts = pts[:-1]
        pts[i], pts[i + 1] = pts[i + 1], pts[i]
        pts = pts + [pts[0]]
        desc = f"{k} points, {i} and {i + 1} swapped"
    elif kind == "few points":
        m = data.draw(st.integers(0, 2), label="distinct")
        pts = pts[:m] + pts[:1] if m else data.draw(st.sampled_from([[], [[0, 0]]]), label="points")
        desc = f"{m} distinct points"
    elif kind == "non-finite":
        i, c = data.draw(st.integers(0, k), label="point"), data.draw(st.integers(0, 1), label="coordinate")
        v = data.draw(NON_FINITE, label="value")
        pts[i][c] = v
        desc = f"point {i}[{c}] = {show(v)}"
    elif kind == "strings":
        i, c = data.draw(st.integers(0, k), label="point"), data.draw(st.integers(0, 1), label="coordinate")
        v = data.draw(st.one_of(st.text(max_size=5), st.just(str(pts[i][c])), st.none(), st.booleans()), label="v")
        pts[i][c] = v
        desc = f"point {i}[{c}] = {show(v)}"
    elif kind == "nested":
        how = data.draw(st.sampled_from(["3d points", "deeper", "flat", "ragged", "dict points", "scalar points"]),
                        label="how")
        pts = {"3d points": [p + [0.0] for p in pts], "deeper": [[p] for p in pts],
               "flat": [v for p in pts for v in p], "ragged": pts[:2] + [pts[2][:1]] + pts[3:],
               "dict points": [{"x": p[0], "y": p[1]} for p in pts], "scalar points": [p[0] for p in pts]}[how]
        desc = f"points {how}"
    elif kind == "repeated vertex":
        i = data.draw(st.integers(0, k - 2), label="vertex")
        pts = pts[:i + 1] + [pts[i]] + pts[i + 1:]
        desc = f"vertex {i} twice in a row"
    elif kind == "collinear":
        m = data.draw(st.integers(3, 8), label="points")
        slope = data.draw(finite(-5, 5), label="slope")
        pts = [[float(x), slope * x] for x in range(m)] + [[0.0, 0.0]]
        desc = f"{m} collinear points"
    elif kind == "not points":
        pts = data.draw(st.one_of(st.integers(), st.text(max_size=5), st.none(), st.booleans(),
                                  st.dictionaries(st.sampled_from(["x", "y"]), st.integers(), max_size=2)),
                        label="points")
        desc = f"points = {show(pts)}"
    elif kind == "name":
        wrap = True
        name = data.draw(st.one_of(st.integers(), st.lists(st.integers(), max_size=2), st.booleans(),
                                   st.dictionaries(st.sampled_from(["a"]), st.integers(), max_size=1)), label="name")
        desc = f"name = {show(name)}"
    elif kind == "too many":
        m = data.draw(st.sampled_from([20_001, 50_000, 200_000]), label="points")
        a = np.linspace(0, 2 * np.pi, m, endpoint=False)
        pts = np.c_[np.cos(a), np.sin(a)].tolist()
        pts = pts + pts[:1]
        desc = f"{m} points"
    else:
        desc = None
    with case_dir() as t:
        f = t / "outline.json"
        obj = {"name": "fuzz", "points": pts} if wrap else pts
        if name is not None:
            obj["name"] = name
        f.write_text(dumps(obj))
        if kind == "json":
            desc, fn = draw_json_damage(data, f)
            fn()
        out = t / "out"
        refused("polygon files", f"{kind}: {desc}", ["dataset", "--polygon", f, "--out", out, "--views", "1",
                                                      "--val", "0", "--test", "1", "--resolution", "4", "--spp", "1"],
                t, out)


# ------------------------------------------------------------------------------ Mitsuba XML

XML = """<scene version="3.0.0">
    <bsdf type="diffuse" id="mat"><rgb name="reflectance" value="0.5"/></bsdf>
    <shape type="sphere"><float name="radius" value="0.5"/><ref id="mat"/></shape>
    <shape type="ply"><string name="filename" value="{ply}"/><ref id="mat"/></shape>
    <emitter type="point"><point name="position" x="0" y="0" z="5"/><rgb name="intensity" value="20"/></emitter>
</scene>
"""


@examples(0.75)
@given(data=st.data())
def test_mitsuba_xml_files(base, data):
    kind = data.draw(st.sampled_from(["truncated", "unknown plugin", "missing file", "junk", "root", "bad value",
                                      "unknown property", "undefined variable", "include", "no shapes"]),
                     label="kind")
    text = XML.format(ply=base["ply"])
    if kind == "truncated":
        cut = data.draw(st.integers(0, text.rindex("</scene>") - 1), label="cut at")
        text, desc = text[:cut], f"cut at {cut}"
    elif kind == "unknown plugin":
        which = data.draw(st.sampled_from(["sphere", "diffuse", "point", "ply"]), label="plugin")
        name = "x_" + data.draw(st.text(string.ascii_lowercase + "_", min_size=1, max_size=10), label="name")
        text, desc = text.replace(f'type="{which}"', f'type="{name}"'), f"{which} -> {name}"
    elif kind == "missing file":
        name = data.draw(st.text(string.ascii_letters + " _-üé", min_size=1, max_size=12), label="file")
        text, desc = text.replace(str(base["ply"]), f"/nonexistent/{name}.ply"), f"no {name}.ply"
        if data.draw(st.booleans(), label="texture"):
            text = XML.format(ply=base["ply"]).replace('<rgb name="reflectance" value="0.5"/>',
                                                       f'<texture type="bitmap" name="reflectance"><string '
                                                       f'name="filename" value="{name}.png"/></texture>')
            desc = f"no texture {name}.png"
    elif kind == "junk":
        junk = data.draw(st.binary(max_size=40), label="junk")
        text, desc = None, f"junk {junk!r}"
    elif kind == "root":
        text = data.draw(st.sampled_from(['<shape type="sphere" version="3.0.0"/>',
                                          '<bsdf type="diffuse" version="3.0.0"/>', '<scene/>',
                                          '<emitter type="point" version="3.0.0"/>', '<?xml version="1.0"?>']),
                         label="root")
        desc = text
    elif kind == "bad value":
        v = data.draw(st.sampled_from(["abc", "1,5", "--1", "0x", "1e"]), label="value")    # Mitsuba reads "" as 0
        text, desc = text.replace('name="radius" value="0.5"', f'name="radius" value="{v}"'), f"radius = {v!r}"
    elif kind == "unknown property":
        name = "x_" + data.draw(st.text(string.ascii_lowercase, min_size=1, max_size=8), label="name")
        text = text.replace('<float name="radius" value="0.5"/>', f'<float name="{name}" value="1"/>')
        desc = f"property {name}"
    elif kind == "undefined variable":
        name = data.draw(st.text(string.ascii_lowercase, min_size=1, max_size=8), label="name")
        text, desc = text.replace(str(base["ply"]), f"${name}"), f"${name}"
    elif kind == "include":
        name = data.draw(st.text(string.ascii_letters, min_size=1, max_size=8), label="name")
        text = text.replace("</scene>", f'<include filename="{name}.xml"/></scene>')
        desc = f"include {name}.xml"
    else:
        text, desc = XML.format(ply=base["ply"]).split("<shape")[0] + XML.split("</shape>")[-1], "no shapes"
    with case_dir() as t:
        f = t / "scene.xml"
        f.write_bytes(junk) if text is None else f.write_text(text)
        out = t / "out"
        argv = ["dataset", "--scene", f, "--out", out, "--views", "1", "--val", "0", "--test", "1", "--resolution",
                "4", "--spp", "1"]
        refused("Mitsuba XML files", f"{kind}: {desc}", argv, t, out)


# -------------------------------------------------------------------------- numeric flags

def bad_value(integer: bool, lo, hi, strict_lo: bool, also_bad=()) -> st.SearchStrategy:
    """Text that is not a number in ``[lo, hi]`` (``(lo, hi]`` with ``strict_lo``), whole if ``integer``."""
    def not_a_number(s: str) -> bool:
        try:
            float(s)
            return False
        except ValueError:
            return True
    nums = [st.sampled_from(["nan", "NaN", "inf", "-inf", "infinity", "1e400", "-1e400"]),
            st.text(max_size=6).filter(lambda s: not_a_number(s) and s != "--"),    # "--": test_double_dash...
            st.sampled_from(["", " ", "1,5", "0x10", "1/2", "ten", "1e", "---", "½", "1 2"])]
    if lo is not None:
        nums.append(finite(-1e300, lo).filter(lambda v: v < lo or (strict_lo and v <= lo)).map(repr))
        if integer:
            nums.append(st.integers(-10 ** 20, lo - 1).map(str))
    if hi is not None:
        nums.append(finite(hi * 1.0001 + 1e-9, 1e300).map(repr))
        if integer:
            nums.append(st.integers(int(hi) + 1, 10 ** 30).map(str))
    if integer:
        nums.append(finite(-1e6, 1e6).filter(lambda v: not v.is_integer()).map(repr))
    if also_bad:
        nums.append(st.sampled_from(list(also_bad)))
    return st.one_of(nums)


# flag: (integer, lo, hi, strict_lo, extra values refused after parsing)
FIT_FLAGS = {"--iters": (True, 1, 10 ** 9, False), "--time-budget": (False, 0, 10 ** 7, True),
             "--batch": (True, 1, 1 << 22, False), "--lr": (False, 0, 10, True), "--lr-final": (False, 0, 10, True),
             "--seed": (True, 0, 2 ** 32 - 1, False), "--val-every": (True, 0, 10 ** 9, False),
             "--threads": (True, 1, 1024, False), "--depth-weight": (False, 0, 1e6, False),
             "--depth-sigma": (False, 0, 1e6, True), "--samples": (True, 1, 4096, False),
             "--fine": (True, 0, 4096, False), "--width": (True, 2, 1024, False), "--depth": (True, 1, 32, False),
             "--pos-L": (True, 0, 24, False), "--dir-L": (True, 0, 12, False),
             "--resolution": (True, 2, 8193, False)}
DATASET_FLAGS = {"--views": (True, 0, 100_000, False, ["0"]), "--val": (True, 0, 100_000, False),
                 "--test": (True, 0, 100_000, False), "--resolution": (True, 0, 16384, False, ["0"]),
                 "--radius": (False, 0, 1e4, True), "--fov": (False, 0, 179, True), "--noise": (False, 0, 100, False),
                 "--radius-std": (False, 0, 1e4, False), "--angle-std": (False, 0, 1e4, False),
                 "--position-std": (False, 0, 1e4, False), "--look-std": (False, 0, 1e4, False),
                 "--spp": (True, 1, 1 << 16, False), "--seed": (True, 0, 2 ** 32 - 1, False)}
VIDEO_FLAGS = {"--frames": (True, 1, 100_000, False), "--resolution": (True, 1, 4096, False, ["1"]),
               "--elevation": (False, -90, 90, False, ["89.95", "-89.95", "90", "-90"]),
               "--radius": (False, 0, 1e4, True), "--fov": (False, 0, 179, True), "--fps": (False, 0, 1000, True),
               "--mesh-resolution": (True, 2, 1024, False), "--chamfer-points": (True, 1, 10 ** 7, False)}
SWEEP_FLAGS = {"--workers": (True, 1, 256, False), "--threads": (True, 1, 256, False),
               "--seed": (True, 0, 2 ** 31, False)}
EXPERIMENT_FLAGS = {"--seed": (True, 0, 2 ** 31, False)}


def draw_flag(data, table: dict) -> tuple[str, str]:
    flag = data.draw(st.sampled_from(sorted(table)), label="flag")
    integer, lo, hi, strict, *extra = table[flag]
    value = data.draw(bad_value(integer, lo, hi, strict, extra[0] if extra else ()), label="value")
    return flag, value


def as_args(data, flag: str, value: str) -> list[str]:
    return [f"{flag}={value}"] if data.draw(st.booleans(), label="flag=value") or value.startswith("-") else \
        [flag, value]


@examples(1.5)
@given(data=st.data())
def test_fit_flags(base, data):
    kind = data.draw(st.sampled_from(["number"] * 6 + ["choice", "set", "recipe"]), label="kind")
    if kind == "number":
        flag, value = draw_flag(data, FIT_FLAGS)
        extra = as_args(data, flag, value)
        desc = f"{flag} {value!r}"
    elif kind == "choice":
        flag = data.draw(st.sampled_from(["--background", "--method", "--density-activation", "--backend"]))
        value = data.draw(st.one_of(st.text(max_size=8), st.sampled_from(["1,1", "0,0,2", "-1,0,0", "nan,0,0",
                                                                          "grey", "1,1,1,1", "WHITE"])), label="v")
        valid = {"--method": ["replay", "autodiff"], "--density-activation": ["relu", "softplus", "trunc_exp"],
                 "--backend": ["drjit", "torch"], "--background": ["black", "white"]}[flag]
        if value in valid or (flag == "--background" and _rgb_ok(value)):
            value = "nope"
        extra, desc = as_args(data, flag, value), f"{flag} {value!r}"
    elif kind == "set":
        how = data.draw(st.sampled_from(["unknown", "no =", "bad value", "occupancy", "wrong type"]), label="set")
        if how == "unknown":
            key = "x" + data.draw(st.text(string.ascii_letters + "_.", max_size=8), label="key")
            if "." in key:
                key = key.replace(".", "_")
            value = data.draw(st.sampled_from(["1", "true", "[1,2]", "abc", "null"]), label="value")
            extra = ["--set", f"{key}={value}"]
        elif how == "no =":
            key = data.draw(st.text(string.ascii_letters, max_size=8), label="key")
            extra = ["--set", key]
        elif how == "wrong type":        # the grid-2d recipe's settings (the default 2D recipe)
            key, kind = data.draw(st.sampled_from([("upsample_at", "list"), ("resolution", "number"),
                                                   ("tv_weight", "number"), ("keep_best", "bool"),
                                                   ("view_dependent", "bool"), ("lr", "number"),
                                                   ("density_activation", "string"), ("background", "list"),
                                                   ("occupancy.enabled", "bool")]), label="key")
            value = data.draw(st.sampled_from([v for k, v in [("number", "1"), ("number", "2.5"), ("bool", "true"),
                                                              ("list", "[1, 2]"), ("list", '["a"]'),
                                                              ("string", '"x"'), ("string", "{}")]
                                               if k != kind] + (['["x", "y"]'] if kind == "list" else [])),
                              label="value")
            extra = ["--set", f"{key}={value}"]
        elif how == "occupancy":
            key = "occupancy.x" + data.draw(st.text(string.ascii_letters, max_size=6), label="key")
            extra = ["--set", f"{key}=1"]
        else:
            key = data.draw(st.sampled_from(["iters", "lr", "batch_rays", "beta1", "warmup", "val_views", "eps",
                                             "n_coarse", "n_fine", "background", "coarse_weight"]), label="key")
            value = data.draw(st.sampled_from(["-1", "0.0", "1e400", "NaN", '"text"', "[1, 2]", "{}", "true",
                                               "[0, 0, 2]", "-1e-9"]), label="value")
            if value == "0.0" and key in ("n_fine", "warmup", "coarse_weight", "beta1", "beta2", "eps"):
                value = "-1"
            if key == "background" and value in ("-1", "0.0", "-1e-9"):
                value = "[0, 0, 2]"
            extra = ["--set", f"{key}={value}"]
        desc = f"--set {extra[1]!r} ({how})"
    else:
        flag = data.draw(st.sampled_from(["--recipe", "--field"]), label="flag")
        value = "x" + data.draw(st.text(max_size=8), label="name")
        extra, desc = as_args(data, flag, value), f"{flag} {value!r}"
    with case_dir() as t:
        out = t / "out"
        refused("command-line values: fit", desc, ["fit", "--data", base["nerf2d"], "--iters", "1", "--out", out,
                                                    *extra], t, out)


def _rgb_ok(text: str) -> bool:
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        return False
    return len(v) == 3 and all(0 <= x <= 1 for x in v)


@examples(1.0)
@given(data=st.data())
def test_dataset_flags(base, data):
    flag, value = draw_flag(data, DATASET_FLAGS)
    with case_dir() as t:
        out = t / "out"
        argv = ["dataset", "--scene", "square", "--out", out, "--views", "1", "--val", "0", "--test", "1",
                "--resolution", "4", "--spp", "1", *as_args(data, flag, value)]
        refused("command-line values: dataset", f"{flag} {value!r}", argv, t, out)


@examples(1.0)
@given(data=st.data())
def test_video_flags(base, data):
    if data.draw(st.integers(0, 5), label="level") == 0:
        flag, value = "--level", data.draw(st.one_of(st.sampled_from(["0", "-1", "nan", "inf", "-inf", "", "AUTO"]),
                                                     st.text(max_size=5).filter(lambda s: s != "auto"
                                                                                and not _is_positive(s))), label="v")
        if value in ("inf", "1e400"):   # refused only after the video: see test_an_infinite_mesh_level
            value = "-inf"
    else:
        flag, value = draw_flag(data, VIDEO_FLAGS)
    with case_dir() as t:
        out = t / "out"
        argv = ["video", "--checkpoint", base["ckpt3"], "--out", out, "--frames", "2", "--resolution", "4",
                "--mesh-resolution", "8", "--chamfer-points", "10", "--level", "auto", *as_args(data, flag, value)]
        refused("command-line values: video", f"{flag} {value!r}", argv, t, out)


def _is_positive(s: str) -> bool:
    try:
        return float(s) > 0
    except ValueError:
        return False


def test_an_infinite_mesh_level(base):
    with case_dir() as t:
        out = t / "out"
        refused("fixed cases", "video --level inf", ["video", "--checkpoint", base["ckpt3"], "--out", out, "--frames",
                                                     "2", "--resolution", "4", "--mesh-resolution", "8", "--level",
                                                     "inf"], t, out)


@examples(0.75)
@given(data=st.data())
def test_sweep_and_experiment_flags(base, data):
    cmd = data.draw(st.sampled_from(["sweep", "experiment"]), label="command")
    with case_dir() as t:
        out = t / "out"
        if cmd == "sweep":
            kind = data.draw(st.sampled_from(["number", "budget", "executor"]), label="kind")
            if kind == "number":
                flag, value = draw_flag(data, SWEEP_FLAGS)
                extra, desc = as_args(data, flag, value), f"{flag} {value!r}"
            elif kind == "budget":
                value = data.draw(st.one_of(
                    st.sampled_from(["", "s", "it", "20", "20m", "0s", "0it", "-5it", "5.5it", "1e3it", "nans", "infs",
                                     "1e7s", "-1s", "twenty s"]),
                    st.integers(-10 ** 6, 0).map(lambda v: f"{v}it"), finite(1e7, 1e300).map(lambda v: f"{v!r}s"),
                    st.text(string.ascii_letters + " ", max_size=6).map(lambda s: s + "it")), label="budget")
                extra, desc = ["--budgets", "20s", value], f"--budgets {value!r}"
            else:
                extra, desc = ["--executor", "dask"], "--executor dask without --scheduler"
            argv = ["sweep", "--out", out, "--quick", *extra]
        else:
            name = data.draw(st.sampled_from(["pe", "depth", "stability", "window-shop", "pixelnerf"]), label="name")
            kind = data.draw(st.sampled_from(["number", "unknown setting", "unknown experiment"]), label="kind")
            if kind == "number":
                flag, value = draw_flag(data, EXPERIMENT_FLAGS)
                extra, desc = as_args(data, flag, value), f"{name} {flag} {value!r}"
            elif kind == "unknown setting":
                key = "x" + data.draw(st.text(string.ascii_letters + "_", max_size=8), label="key")
                extra, desc = ["--set", f"{key}=1"], f"{name} --set {key}=1"
            else:
                name = "x" + data.draw(st.text(string.ascii_letters + "-", max_size=8), label="name")
                extra, desc = [], f"experiment {name!r}"
            argv = ["experiment", name, "--out", out, "--quick", *extra]
        refused(f"command-line values: {cmd}", desc, argv, t, out)


# ------------------------------------------------------------------------------ checkpoints

def manifest_damage(data, m: dict, resume: bool) -> tuple[str, callable]:
    """A hand-edited manifest.json (``m`` is the valid one); ``resume``: for ``fit --resume``,
    which reads the dataset the manifest names."""
    key = data.draw(st.sampled_from(["format", "version", "dim", "field", "bounds", "arrays", "recipe", "loop",
                                     "dataset", "best", "missing"]), label="manifest key")
    if key == "format":
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.sampled_from(["mitnerf-checkpoint-v3", "nerf"])), label="v")
        return f"format = {show(v)}", lambda o: o.__setitem__("format", v)
    if key == "version":
        v = data.draw(st.one_of(st.integers(3, 10 ** 9), st.integers(-5, 1), WRONG_TYPE_OR_NULL,
                                st.sampled_from([2.0, 2.5, True])), label="version")
        return f"version = {show(v)}", lambda o: o.__setitem__("version", v)
    if key == "dim":
        v = data.draw(st.one_of(st.integers().filter(lambda d: d != m["dim"]), WRONG_TYPE_OR_NULL), label="dim")
        return f"dim = {show(v)}", lambda o: o.__setitem__("dim", v)
    if key == "field":
        v = data.draw(st.one_of(st.sampled_from(["grid", "hashgrid", "pixelnerf", "nope", ""]), WRONG_TYPE_OR_NULL
                                .filter(lambda v: v != m["field"])), label="field")
        return f"field = {show(v)}", lambda o: o.__setitem__("field", v)
    if key == "bounds":
        k = data.draw(st.sampled_from(["bound", "near", "far"]), label="bound")
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, NON_FINITE, finite(-1e9, -1e-9) if k != "far" else st.nothing(),
                                st.just(0.0) if k == "bound" else st.nothing(),
                                finite(m["far"], 1e9) if k == "near" else finite(-1e9, m["near"]) if k == "far"
                                else st.nothing()), label=k)
        return f"{k} = {show(v)}", lambda o: o.__setitem__(k, v)
    if key == "arrays":
        f = data.draw(st.sampled_from(["weights.npz", "state.npz"]), label="file")
        name = data.draw(st.sampled_from(sorted(m["arrays"][f])), label="array")
        what = data.draw(st.sampled_from(["shape", "dtype", "sha256", "remove", "add", "entry", "file entry"]),
                         label="what")
        if what == "shape":
            s = data.draw(st.lists(st.integers(0, 64), max_size=3).filter(
                lambda s: s != m["arrays"][f][name]["shape"]), label="shape")
            return f"{f} {name} shape = {s}", lambda o: o["arrays"][f][name].__setitem__("shape", s)
        if what == "dtype":
            d = data.draw(st.sampled_from(["float64", "int32", "float16", "<U1", "object"]), label="dtype")
            return f"{f} {name} dtype = {d}", lambda o: o["arrays"][f][name].__setitem__("dtype", d)
        if what == "sha256":
            h = data.draw(st.one_of(st.text("0123456789abcdef", min_size=64, max_size=64), WRONG_TYPE_OR_NULL),
                          label="sha")
            return f"{f} {name} sha256 = {show(h)}", lambda o: o["arrays"][f][name].__setitem__("sha256", h)
        if what == "remove":
            return f"{f} {name} not listed", lambda o: o["arrays"][f].pop(name)
        if what == "add":
            return f"{f} lists an extra array", lambda o: o["arrays"][f].__setitem__(
                "extra.x", {"shape": [1], "dtype": "float32", "sha256": "0" * 64})
        if what == "entry":
            v = data.draw(WRONG_TYPE_OR_NULL, label="entry")
            return f"{f} {name} entry = {show(v)}", lambda o: o["arrays"][f].__setitem__(name, v)
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.just({})), label="entry")
        return f"{f} entry = {show(v)}", lambda o: o["arrays"].__setitem__(f, v)
    if key == "recipe":
        what = data.draw(st.sampled_from(["width", "depth", "pos_L", "n_coarse", "lr", "iters", "whole", "field",
                                          "dim", "name"]), label="recipe key")
        if what in ("width", "depth", "pos_L"):
            old = m["recipe"]["model"]["field_args"][what]
            v = data.draw(st.one_of(st.integers(-3, 40).filter(lambda x: x != old), WRONG_TYPE_OR_NULL), label=what)
            return f"recipe {what} = {show(v)}", lambda o: o["recipe"]["model"]["field_args"].__setitem__(what, v)
        if what == "n_coarse":
            v = data.draw(st.one_of(st.integers(-5, 0), WRONG_TYPE_OR_NULL, NON_FINITE), label="n_coarse")
            return f"recipe n_coarse = {show(v)}", lambda o: o["recipe"]["model"]["render"].__setitem__("n_coarse", v)
        if what in ("lr", "iters"):
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, NON_FINITE, finite(-1e9, 0)), label=what)
            return f"recipe {what} = {show(v)}", lambda o: o["recipe"]["train"].__setitem__(what, v)
        if what == "whole":
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.just({})), label="recipe")
            return f"recipe = {show(v)}", lambda o: o.__setitem__("recipe", v)
        if what == "field":
            v = data.draw(st.sampled_from(["grid", "hashgrid", "nope"]), label="field")
            return f"recipe field = {v}", lambda o: o["recipe"]["model"].__setitem__("field", v)
        if what == "dim":
            v = data.draw(st.one_of(st.integers().filter(lambda d: d != m["dim"]), st.text(max_size=2)), label="dim")
            return f"recipe dim = {show(v)}", lambda o: o["recipe"].__setitem__("dim", v)
        v = data.draw(st.one_of(st.integers(), st.none(), st.lists(st.integers(), max_size=2)), label="name")
        return f"recipe name = {show(v)}", lambda o: o["recipe"].__setitem__("name", v)
    if key == "loop":
        v = data.draw(st.one_of(WRONG_TYPE_OR_NULL, st.fixed_dictionaries({"step": st.one_of(
            WRONG_TYPE_OR_NULL, st.integers(-10, -1), NON_FINITE)}), st.fixed_dictionaries({"step": st.just(2),
                                                                                          "train_time": st.one_of(
                WRONG_TYPE_OR_NULL, NON_FINITE, finite(-1e9, -1e-9))})), label="loop")
        return f"loop = {show(v)}", lambda o: o.__setitem__("loop", v)
    if key == "dataset":
        v = data.draw(st.one_of(st.text(max_size=4), st.integers(), st.lists(st.integers(), max_size=2),
                                st.booleans(), st.fixed_dictionaries({"mesh": st.one_of(st.integers(),
                                                                                        st.lists(st.integers()))}),
                                st.fixed_dictionaries({"path": st.integers()}),
                                st.fixed_dictionaries({"path": st.text(string.ascii_letters, min_size=1, max_size=8)
                                                       .map(lambda s: f"/nonexistent/{s}")}) if resume
                                else st.nothing()), label="dataset")
        return f"dataset = {show(v)}", lambda o: o.__setitem__("dataset", v)
    if key == "best":
        v = data.draw(st.one_of(st.text(min_size=1, max_size=4), st.integers(), st.lists(st.integers(), min_size=1,
                                                                                         max_size=2), st.booleans()),
                      label="best")
        return f"best = {show(v)}", lambda o: o.__setitem__("best", v)
    k = data.draw(st.sampled_from(["format", "version", "dim", "field", "arrays", "recipe", "bound", "near", "far",
                                   "loop"]), label="missing")
    return f"no {k}", lambda o: o.pop(k)


def array_edit(data, ck: Path, m: dict) -> tuple[str, callable]:
    """An .npz of the checkpoint whose arrays changed (consistently with the manifest or not)."""
    f = data.draw(st.sampled_from(["weights.npz", "state.npz"]), label="file")
    with np.load(ck / f) as z:
        arrays = {k: z[k] for k in z.files}
    name = data.draw(st.sampled_from(sorted(arrays)), label="array")
    what = data.draw(st.sampled_from(["value", "nan", "reshape", "drop", "add", "dtype"]), label="edit")
    listed = json.loads(json.dumps(m["arrays"]))
    a = arrays[name]
    if what == "value":
        arrays[name] = a + np.ones_like(a)
        consistent = False
    elif what == "nan":
        b = a.astype(np.float32).copy().reshape(-1)
        if b.size == 0:
            b = np.zeros(1, np.float32)
        b[data.draw(st.integers(0, b.size - 1), label="index")] = data.draw(st.sampled_from([NAN, INF, -INF]))
        arrays[name] = b.reshape(a.shape) if b.size == a.size else b
        consistent = True
    elif what == "reshape":
        arrays[name] = np.zeros((a.size + data.draw(st.integers(1, 9), label="more"),), np.float32)
        consistent = data.draw(st.booleans(), label="manifest updated")
    elif what == "drop":
        arrays.pop(name)
        consistent = data.draw(st.booleans(), label="manifest updated")
    elif what == "add":
        arrays["extra.x"] = np.zeros(3, np.float32)
        consistent = data.draw(st.booleans(), label="manifest updated")
    else:       # another float type with the manifest updated is the same model: text is not
        consistent = data.draw(st.booleans(), label="manifest updated")
        arrays[name] = a.astype(str) if consistent else a.astype(np.float64 if a.dtype != np.float64 else np.float32)

    def fn():
        raw = npz_bytes(**arrays)
        (ck / f).write_bytes(raw)
        if consistent:
            from mitnerf.train.checkpoint import _npz_bytes

            listed[f] = _npz_bytes(arrays)[1]
            edit_json(ck / "manifest.json", lambda o: o.__setitem__("arrays", listed))
    return f"{f} {name}: {what}{' (manifest updated)' if consistent else ''}", fn


@examples(1.5)
@given(data=st.data())
def test_checkpoints(base, data):
    cmd = data.draw(st.sampled_from(["video", "resume", "resume", "video 2D"]), label="command")
    src = base["ckpt2"] if cmd == "video 2D" or (cmd == "resume" and data.draw(st.booleans(), label="2D")) \
        else base["ckpt3"]
    m = json.loads((src / "manifest.json").read_text())
    with case_dir() as t:
        ck = t / "run"
        shutil.copytree(src, ck)
        if cmd == "video 2D":
            desc, fn = "a 2D checkpoint", lambda: None
        else:
            what = data.draw(st.sampled_from(["manifest", "manifest file", "weights file", "state file", "arrays",
                                              "not a checkpoint", "resume flags"] if cmd == "resume" else
                                             ["manifest", "manifest file", "weights file", "state file", "arrays",
                                              "not a checkpoint"]), label="what")
            if what == "manifest":
                desc, edit = manifest_damage(data, m, resume=cmd == "resume")
                fn = lambda: edit_json(ck / "manifest.json", edit)  # noqa: E731
            elif what == "manifest file":
                desc, fn = draw_json_damage(data, ck / "manifest.json")
                desc = f"manifest.json {desc}"
                if data.draw(st.booleans(), label="or missing"):
                    desc, fn = draw_file_damage(data, ck / "manifest.json", "manifest.json")
            elif what in ("weights file", "state file"):
                f = "weights.npz" if what == "weights file" else "state.npz"
                desc, fn = draw_file_damage(data, ck / f, f)
            elif what == "arrays":
                desc, fn = array_edit(data, ck, m)
            elif what == "not a checkpoint":
                desc, fn = "an empty folder", lambda: [p.unlink() for p in ck.iterdir() if p.is_file()]
                if data.draw(st.booleans(), label="a dataset"):
                    shutil.rmtree(ck)
                    desc, fn = "a dataset folder", lambda: shutil.copytree(base["nerf2d"], ck)
            else:
                flag = data.draw(st.sampled_from([["--lr", "0.01"], ["--field", "grid"], ["--recipe", "vanilla-3d"],
                                                  ["--auto"], ["--set", "lr=0.1"], ["--iters", "5"]]), label="flag")
                desc, fn = f"--resume with {' '.join(flag)}", lambda: None
        fn()
        out = t / "video"
        if cmd.startswith("video"):
            argv = ["video", "--checkpoint", ck, "--out", out, "--frames", "2", "--resolution", "4",
                    "--mesh-resolution", "8", "--chamfer-points", "10", "--level", "auto"]
        else:
            argv = ["fit", "--resume", ck, *(flag if what == "resume flags" else [])]
        refused(f"checkpoints: {cmd.split()[0]}", f"{src.name}: {desc}", argv, t, out)


# ---------------------------------------------------------------- fixed cases, subprocesses

@pytest.mark.parametrize("case", ["video of a 2D checkpoint", "newer checkpoint format", "training memory",
                                  "dataset memory", "video memory"])
def test_fixed_cases(base, case):
    with case_dir() as t:
        out = t / "out"
        if case == "video of a 2D checkpoint":
            shutil.copytree(base["ckpt2"], t / "run")
            line = refused("fixed cases", case, ["video", "--checkpoint", t / "run", "--out", out], t, out)
            assert "needs a 3D one" in line
        elif case == "newer checkpoint format":
            shutil.copytree(base["ckpt3"], t / "run")
            edit_json(t / "run" / "manifest.json", lambda o: o.__setitem__("version", 3))
            line = refused("fixed cases", case, ["video", "--checkpoint", t / "run", "--out", out], t, out)
            assert "newer mitnerf" in line and "upgrade" in line
        elif case == "training memory":
            line = refused("fixed cases", case, ["fit", "--data", base["nerf2d"], "--iters", "1", "--field", "vanilla",
                                                 "--batch", str(1 << 22), "--samples", "4096", "--fine", "4096",
                                                 "--out", out], t, out)
            assert "GiB" in line
        elif case == "dataset memory":
            line = refused("fixed cases", case, ["dataset", "--scene", "vase", "--views", "100000", "--resolution",
                                                 "16384", "--out", out], t, out)
            assert "GiB" in line
        else:
            line = refused("fixed cases", case, ["video", "--checkpoint", base["ckpt3"], "--frames", "100000",
                                                 "--resolution", "4096", "--out", out], t, out)
            assert "GiB" in line


@pytest.mark.parametrize("argv", [["sweep", "--quick", "--scenes", "teapot"],
                                  ["experiment", "pe", "--quick", "--set", "steps=-5"]])
def test_settings_checked_after_the_output_is_claimed(argv):
    with case_dir() as t:
        out = t / "out"
        refused("fixed cases", " ".join(argv), [*argv, "--out", out], t, out)


@pytest.mark.parametrize("argv", [["video", "--checkpoint", "{ckpt3}", "--frames=--"],
                                  ["dataset", "--scene", "square", "--views=--"]])
def test_double_dash_as_a_value(base, argv):
    with case_dir() as t:
        out = t / "out"
        argv = [a.format(ckpt3=base["ckpt3"]) for a in argv]
        refused("fixed cases", " ".join(a for a in argv if "/" not in a), [*argv, "--out", out], t, out)


def test_the_real_stderr_of_a_few_cases(base):
    """In a subprocess: what a user sees (C++ logs, Python warnings), exactly one line."""
    with case_dir() as t:
        (t / "scene.xml").write_text(XML.format(ply=base["ply"]).replace('type="sphere"', 'type="x_teapot"'))
        shutil.copytree(base["blender"], t / "ds")
        (t / "ds" / "train" / "r_1.png").write_bytes((t / "ds" / "train" / "r_1.png").read_bytes()[:40])
        shutil.copytree(base["ckpt3"], t / "run")
        (t / "run" / "weights.npz").write_bytes((t / "run" / "weights.npz").read_bytes()[:100])
        cases = {"xml": ["dataset", "--scene", t / "scene.xml", "--out", t / "o1"],
                 "png": ["fit", "--data", t / "ds", "--out", t / "o2"],
                 "ckpt": ["video", "--checkpoint", t / "run", "--out", t / "o3"]}
        procs = {k: subprocess.Popen([sys.executable, "-m", "mitnerf", *map(str, v)], cwd=ROOT, text=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE) for k, v in cases.items()}
        for k, p in procs.items():
            stdout, stderr = p.communicate(timeout=120)
            assert p.returncode == 2, (k, stderr)
            assert stderr.count("\n") == 1 and stderr.startswith("mitnerf: error: "), (k, stderr)
            assert stdout == "", (k, stdout)
            CASES["subprocess"].add(k)
        assert sorted(p.name for p in t.iterdir()) == ["ds", "run", "scene.xml"]


@pytest.fixture(scope="module", autouse=True)
def report(request):
    yield
    n = sum(len(v) for v in CASES.values())
    lines = [f"fuzz: {n} distinct hostile cases, all ended in one line, exit 2, nothing written"]
    lines += [f"  {len(v):5d}  {k}" for k, v in sorted(CASES.items())]
    request.config.mitnerf_summary = getattr(request.config, "mitnerf_summary", []) + lines
