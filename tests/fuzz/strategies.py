"""Hypothesis strategies for bad values, and the damage a hand-edited or truncated file
can carry: each draws a breakage that can never be accidentally valid."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

from .harness import INF, NAN


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
