"""What the reader tests share: the command that reads a damaged dataset, and the damage
to NeRF2D's images, arrays and metadata (the foreign formats reuse it)."""

from __future__ import annotations

import io
import json
import shutil
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

from .harness import case_dir, INF, MAX_SIDE, NAN, npz_bytes, png, png_header, refused
from .strategies import (
    bad_bytes, draw_file_damage, draw_json_damage, edit_json, finite, NON_FINITE, show, WRONG_TYPE_OR_NULL)


# ------------------------------------------------------------------------------ the readers

def fit_or_show(data, ds: Path, t: Path, need_test: bool = False):
    """The command that reads the dataset: ``fit`` (always, when the damage is a missing test
    split, which ``show`` accepts) or ``show``."""
    out = t / "out"
    if need_test or data.draw(st.integers(0, 3), label="command") > 0:
        return ["fit", "--data", ds, "--iters", "1", "--out", out], out
    return ["show", ds, "--out", out], out


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


def image_damage(data, img: Path, shape: tuple, others_in_split: bool, may_go: bool = True) -> tuple[str, callable]:
    """A view that cannot be read, or one that does not fit the others: ``shape`` is (H, W); ``may_go``: a
    missing image is an error (not a frame that is skipped)."""
    kind = data.draw(st.sampled_from(["file", "other size", "too large"] if others_in_split
                                     else ["file", "too large"]), label="image damage")
    if kind == "file":
        return draw_file_damage(data, img, "png", may_go)
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
