"""Hostile datasets in the formats of other tools: Blender, nerfstudio (3D and 2D),
instant-ngp, tiny-NeRF npz."""

from __future__ import annotations

import json
import math
import string
from pathlib import Path

import numpy as np
from hypothesis import given, strategies as st

from .harness import BYTES_PER_PIXEL, examples, INF, MAX_SIDE, mem_total, NAN, npz_bytes, npz_with_fake, png, png_header
from .strategies import (
    away_from, bad_focal, draw_file_damage, draw_frames_damage, draw_json_damage, draw_pose_damage, edit_json,
    finite, NON_FINITE, show, WRONG_TYPE, WRONG_TYPE_OR_NULL)
from .readers import check_reader, image_damage, meta_damage, NERF2D_COUNTS


def header_damage(data, header: dict, W: int, H: int, has_fl: bool, has_angle: bool) -> tuple[str, str, object]:
    """A camera header entry of a transforms.json that is wrong: returns (key, desc, value). Off-centre
    principal points on the image, non-square pixels and lens distortion that does not fold inside the image
    are valid, so only their impossible values are drawn."""
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
        folds = finite(-1e6, -5.0) if key in ("k1", "k2", "k3") else st.nothing()     # folds inside 8 x 8 views
        v = data.draw(st.one_of(away_from(0.0, 1e-6, 10.0) if key == "k4" else folds, WRONG_TYPE, NON_FINITE),
                      label=key)
    elif key in ("w", "h"):
        size = W if key == "w" else H
        v = data.draw(st.one_of(WRONG_TYPE, NON_FINITE, st.integers(-10, 10 ** 6).filter(lambda x: x != size),
                                finite(-1e9, 1e9).filter(lambda x: x != size)), label=key)
    elif key in ("cx", "cy"):
        size = W if key == "cx" else H
        v = data.draw(st.one_of(WRONG_TYPE, NON_FINITE, finite(-1e6, -0.01), finite(size + 0.01, 1e6)), label=key)
    elif key in ("fl_x", "fl_y"):
        v = data.draw(st.one_of(bad_focal(max(W, H) if key == "fl_x" else H, allow_null=False),
                                st.sampled_from([[1.0], {"f": 1}])), label=key)
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
    per_view = side * side * BYTES_PER_PIXEL
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
            nowhere = st.text(string.ascii_letters, min_size=1, max_size=8).map(lambda s: f"nope/{s}")
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL.filter(lambda v: not isinstance(v, str)), st.just(""),
                                    nowhere if key != "file_path" else st.nothing()),   # no image: skipped
                          label=key)
            if key == "file_path":      # keep the frame in its split's list
                def fn():
                    edit_json(tj, lambda o: (o["frames"][index].__setitem__(key, v),
                                             o[f"{split}_filenames"].__setitem__(i, v)))
                return f"frame {stem} file_path = {show(v)}", fn
            return f"frame {stem} {key} = {show(v)}", lambda: edit_json(
                tj, lambda o: o["frames"][index].__setitem__(key, v))
        if what == "image":
            desc, fn = image_damage(data, ds / "images" / f"{stem}.png", (H, W), others_in_split=counts[split] > 1,
                                    may_go=False)           # a frame without its image is skipped
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
    what = data.draw(st.sampled_from(["json file", "angle", "no angle", "frames", "file_path", "image",
                                      "few images"]), label="what")
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
        if what == "file_path":              # (a path to no file is a frame without its image: skipped)
            v = data.draw(st.one_of(WRONG_TYPE_OR_NULL.filter(lambda v: not isinstance(v, str)), st.just("")),
                          label="file_path")
            return f"frame {i} file_path = {show(v)}", lambda: edit_json(
                tj, lambda o: o["frames"][i].__setitem__("file_path", v))
        if what == "few images":           # 6 frames: 2 or fewer left give too few training views
            gone = data.draw(st.integers(4, 6), label="images gone")
            return f"{gone} of 6 images missing", lambda: [(ds / "images" / f"r_{k}.png").unlink() for k in range(gone)]
        desc, fn = image_damage(data, ds / "images" / f"r_{i}.png", (8, 8), others_in_split=i > 0, may_go=False)
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
            m = max(3, math.ceil(2 * mem_total() / (side * side * BYTES_PER_PIXEL))) + data.draw(st.integers(0, 3))
            raw = npz_with_fake({k: v for k, v in a.items() if k not in ("images", "poses")} |
                                {"poses": np.resize(a["poses"], (m, 4, 4))},
                                {"images": ((m, side, side, 3), np.float32)})
            return f"{m} images of {side} x {side} (header only)", lambda: path.write_bytes(raw)
        return desc, lambda: path.write_bytes(npz_bytes(**a))

    check_reader("reader: tiny-NeRF npz", data, base["tiny"], damage)
