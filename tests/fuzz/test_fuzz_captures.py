"""Hostile real-capture folders: LLFF, COLMAP (text and binary) and IDR / NeuS, written by our writers from the
3D base dataset (6 views of 8 x 8: view 0 tests, views 1-5 train) and broken in one place each."""

from __future__ import annotations

import io
import math
import shutil
import struct
from pathlib import Path

import numpy as np
from hypothesis import given, strategies as st

from .harness import BYTES_PER_PIXEL, examples, INF, MAX_SIDE, mem_total, NAN, npz_bytes, npz_with_fake, png_header
from .readers import check_reader, image_damage, meta_damage
from .strategies import away_from, bad_bytes, bad_focal, draw_file_damage, finite, show

VIEWS = 6


def too_many_pixels(data) -> tuple[int, int]:
    """``(side, n)``: ``n`` views of ``side x side`` pixels that do not fit in memory (or a side over the limit)."""
    side = data.draw(st.sampled_from([MAX_SIDE, 12000, 20000]), label="side")
    return side, max(VIEWS, math.ceil(2 * mem_total() / (side * side * BYTES_PER_PIXEL)))


def rotation_damage(data, R: np.ndarray) -> tuple[str, np.ndarray]:
    """A 3 x 3 rotation made scaled, sheared, mirrored or of rank 1."""
    kind = data.draw(st.sampled_from(["scaled", "sheared", "mirrored", "rank-1"]), label="rotation damage")
    j = data.draw(st.integers(0, 2), label="column")
    R = R.copy()
    if kind == "scaled":
        s = data.draw(st.one_of(finite(0.0, 0.98), finite(1.02, 1e6)), label="scale")
        return f"rotation scaled by {s:g}", R * s
    if kind == "sheared":
        t = data.draw(away_from(0.0, 0.01, 1e3), label="shear")
        R[:, (j + 1) % 3] += t * R[:, j]
        return f"rotation sheared by {t:g}", R
    if kind == "mirrored":
        R[:, j] *= -1
        return f"column {j} negated", R
    return "rotation of rank 1", np.outer(R[:, 0], np.eye(3)[j])


def npy_damage(data, path: Path, rows: np.ndarray, what: str) -> tuple[str, callable]:
    """An ``.npy`` of the wrong shape or kind, or holding NaN or infinity."""
    kind = data.draw(st.sampled_from(["shape", "dtype", "non-finite"]), label="npy damage")
    if kind == "shape":
        s = data.draw(st.sampled_from([(VIEWS, 15), (VIEWS, 17, 1), (VIEWS - 1, 17), (VIEWS + 1, 17), (17,),
                                       (VIEWS, 18), (0, 17)]), label="shape")
        return f"{what} of shape {s}", lambda: np.save(path, np.resize(rows, s))
    if kind == "dtype":
        v = data.draw(st.sampled_from(["strings", "objects", "complex"]), label="dtype")
        arr = {"strings": np.full(rows.shape, "x"), "objects": np.full(rows.shape, None, dtype=object),
               "complex": rows.astype(np.complex64)}[v]
        return f"{what} of {v}", lambda: np.save(path, arr, allow_pickle=True)
    v = data.draw(st.sampled_from([NAN, INF, -INF]), label="value")
    r, c = data.draw(st.integers(0, rows.shape[0] - 1), label="row"), data.draw(st.integers(0, 16), label="col")
    bad = rows.copy()
    bad[r, c] = v
    return f"{what} [{r}, {c}] = {v}", lambda: np.save(path, bad)


@examples(1.0)
@given(data=st.data())
def test_llff_folders(base, data):
    """poses_bounds.npy (its array, poses, sizes, focal lengths, bounds), the images, mitnerf.json."""
    what = data.draw(st.sampled_from(["file", "array", "pose", "far", "size", "focal", "bounds", "header",
                                      "no images", "image", "extra image", "memory", "meta"]), label="what")
    i = data.draw(st.integers(0, VIEWS - 1), label="view")

    def damage(ds: Path):
        pb = ds / "poses_bounds.npy"
        rows = np.load(pb)
        m = rows[:, :15].reshape(VIEWS, 3, 5)
        if what == "file":
            return draw_file_damage(data, pb, "poses_bounds.npy")
        if what == "array":
            return npy_damage(data, pb, rows, "poses_bounds.npy")
        if what == "pose":
            desc, m[i, :, :3] = rotation_damage(data, m[i, :, :3])
        elif what == "far":
            v = data.draw(finite(1e7, 1e300), label="distance") * data.draw(st.sampled_from([1, -1]), label="sign")
            desc, m[i, 0, 3] = f"position {v:g}", v
        elif what == "size":
            k = data.draw(st.integers(0, 1), label="h or w")
            v = data.draw(st.one_of(finite(-1e9, 0.5), finite(MAX_SIDE + 1, 1e30),
                                    finite(1, 1e4).filter(lambda x: not float(x).is_integer())), label="size")
            desc, m[i, k, 4] = f"{'hw'[k]} of row {i} = {v:g}", v
        elif what == "focal":
            v = data.draw(bad_focal(8, allow_null=False).filter(lambda v: isinstance(v, float)), label="focal")
            desc, m[i, 2, 4] = f"focal of row {i} = {v:g}", v
        elif what == "bounds":
            near = data.draw(st.one_of(finite(-1e9, 0.0), finite(0.1, 10)), label="near")
            far = data.draw(finite(-1e9, near) if near > 0 else finite(near, 1e9), label="far")
            desc, rows[i, 15:] = f"bounds of row {i} = ({near:g}, {far:g})", (near, far)
        elif what == "header":
            n = data.draw(st.integers(10 ** 6, 10 ** 12), label="rows")
            head = io.BytesIO()
            np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False, "shape": (n, 17)})
            return f"a header claiming {n} rows", lambda: pb.write_bytes(head.getvalue())
        elif what == "no images":
            return "no images/ folder", lambda: shutil.rmtree(ds / "images")
        elif what == "image":
            desc, fn = image_damage(data, ds / "images" / f"{i:04d}.png", (8, 8), others_in_split=True)
            return f"{i:04d}.png: {desc}", fn
        elif what == "extra image":
            return "an extra image", lambda: shutil.copy(ds / "images" / "0000.png", ds / "images" / "0006.png")
        elif what == "memory":
            side, n = too_many_pixels(data)

            def fn():
                np.save(pb, np.resize(rows, (n, 17)))
                for k in range(n):
                    (ds / "images" / f"{k:04d}.png").write_bytes(png_header(side, side))
            return f"{n} views of {side} x {side} pixels", fn
        else:
            return meta_damage(data, ds / "mitnerf.json")
        rows[:, :15] = m.reshape(VIEWS, 15)
        return desc, lambda: np.save(pb, rows)

    check_reader("reader: LLFF", data, base["llff"], damage)


def text_line(path: Path, index: int, line: str) -> callable:
    """Replace the ``index``-th line that is not a comment."""
    def fn():
        lines = path.read_text().splitlines()
        at = [k for k, t in enumerate(lines) if not t.startswith("#")][index]
        lines[at] = line
        path.write_text("\n".join(lines) + "\n")
    return fn


CAMERA = ("PINHOLE", 8, 8)


def bad_camera(data, fx: float) -> str:
    """A cameras.txt line for camera 1 that cannot be read (8 x 8 images, a focal length near ``fx``)."""
    kind = data.draw(st.sampled_from(["tokens", "size", "model", "count", "non-finite", "focal", "centre", "folds",
                                      "rational", "fisheye", "duplicate"]), label="camera damage")
    if kind == "tokens":
        return data.draw(st.sampled_from(["1", "1 PINHOLE", "1 PINHOLE 8"]), label="line")
    if kind == "size":
        w = data.draw(st.sampled_from(["8.5", "x", "-1", "16", "1e3"]), label="width")
        return f"1 PINHOLE {w} 8 {fx} {fx} 4 4"
    if kind == "model":
        name = data.draw(st.text("ABCXYZ_", min_size=1, max_size=8), label="model")
        return f"1 {name} 8 8 {fx} {fx} 4 4"
    if kind == "count":
        n = data.draw(st.sampled_from([0, 1, 2, 3, 5, 8]), label="parameters")
        return "1 PINHOLE 8 8 " + " ".join([str(fx)] * n)
    if kind == "non-finite":
        v = data.draw(st.sampled_from(["nan", "inf", "-inf"]), label="value")
        return f"1 PINHOLE 8 8 {v} {fx} 4 4"
    if kind == "focal":
        v = data.draw(bad_focal(8, allow_null=False).filter(lambda v: isinstance(v, float)), label="focal")
        return f"1 PINHOLE 8 8 {v!r} {fx} 4 4"
    if kind == "centre":
        v = data.draw(st.one_of(finite(-1e6, -0.01), finite(8.01, 1e6)), label="cx")
        return f"1 PINHOLE 8 8 {fx} {fx} {v!r} 4"
    if kind == "folds":
        k = data.draw(finite(-1e6, -5.0), label="k1")
        return f"1 SIMPLE_RADIAL 8 8 {fx} 4 4 {k!r}"
    if kind == "rational":
        k = data.draw(away_from(0.0, 1e-6, 10.0), label="k4")
        return f"1 FULL_OPENCV 8 8 {fx} {fx} 4 4 0 0 0 0 0 {k!r} 0 0"
    if kind == "fisheye":
        return f"1 {data.draw(st.sampled_from(['OPENCV_FISHEYE', 'FOV', 'RADIAL_FISHEYE']), label='model')} 8 8 " + \
            " ".join([str(fx)] * 5)
    return f"1 PINHOLE 8 8 {fx} {fx} 4 4\n1 PINHOLE 8 8 {fx} {fx} 4 4"


def bad_image(data, line: str) -> str:
    """An images.txt line made unreadable: ``line`` is a valid one."""
    t = line.split()
    kind = data.draw(st.sampled_from(["tokens", "text", "quaternion", "translation", "camera", "name"]),
                     label="image damage")
    if kind == "tokens":
        return " ".join(t[:data.draw(st.integers(1, 9), label="tokens")])
    if kind == "text":
        k = data.draw(st.integers(1, 8), label="token")
        t[k] = data.draw(st.sampled_from(["x", "1,5", "0x10", "--1"]), label="value")
    elif kind == "quaternion":
        q = np.array(t[1:5], float)
        v = data.draw(st.one_of(st.sampled_from([NAN, INF]), finite(1.01, 1e6), finite(0.0, 0.99)), label="scale")
        t[1:5] = [repr(x) for x in q * v]
    elif kind == "translation":
        t[5 + data.draw(st.integers(0, 2), label="axis")] = repr(data.draw(st.one_of(
            st.sampled_from([NAN, INF, -INF]), finite(1e7, 1e300)), label="t"))
    elif kind == "camera":
        t[8] = str(data.draw(st.integers(-10, 10 ** 6).filter(lambda c: c != 1), label="camera id"))
    else:
        t[9] = data.draw(st.sampled_from(["../0000.png", "/etc/0000.png", "../images/0001.png"]), label="name")
    return " ".join(t)


def binary_damage(data, path: Path) -> tuple[str, callable]:
    """A .bin file cut short, lengthened, of a huge count, or with an unknown camera model."""
    raw = path.read_bytes()
    kinds = ["cut", "longer", "count", "folder"] + (["model id"] if path.name == "cameras.bin" else [])
    kind = data.draw(st.sampled_from(kinds), label="bin damage")
    if kind == "cut":
        cut = data.draw(st.integers(0, len(raw) - 1), label="cut at")
        return f"{path.name} cut to {cut} of {len(raw)} bytes", lambda: path.write_bytes(raw[:cut])
    if kind == "longer":
        junk = data.draw(bad_bytes(), label="junk")
        return f"{path.name} with {len(junk)} bytes more", lambda: path.write_bytes(raw + junk)
    if kind == "count":
        n = data.draw(st.integers(int.from_bytes(raw[:8], "little") + 1, 2 ** 64 - 1), label="count")
        return f"{path.name} claims {n} records", lambda: path.write_bytes(struct.pack("<Q", n) + raw[8:])
    if kind == "model id":
        m = data.draw(st.one_of(st.integers(-2 ** 31, -1), st.integers(5, 2 ** 31 - 1)), label="model id")
        return f"camera model id {m}", lambda: path.write_bytes(raw[:12] + struct.pack("<i", m) + raw[16:])

    def folder():
        path.unlink()
        path.mkdir()
    return f"{path.name} is a folder", folder


@examples(1.5)
@given(data=st.data())
def test_colmap_folders(base, data):
    """cameras, images and points3D (text and binary), the images, mitnerf.json."""
    binary = data.draw(st.booleans(), label="binary")
    what = data.draw(st.sampled_from(["file", "camera", "image line", "point", "few images", "image", "meta"]),
                     label="what")
    i = data.draw(st.integers(0, VIEWS - 1), label="view")

    def damage(ds: Path):
        model = ds / "sparse" / "0"
        if what == "file":
            name = data.draw(st.sampled_from(["cameras", "images", "points3D"]), label="file")
            path = model / f"{name}.{'bin' if binary else 'txt'}"
            if binary:
                return binary_damage(data, path)
            kinds = (["junk", "utf-16"] + (["empty", "missing"] if name != "points3D" else []))   # no points: valid
            kind = data.draw(st.sampled_from(kinds), label="damage")
            if kind == "junk":
                junk = data.draw(bad_bytes(), label="junk")
                return f"{name}.txt replaced by {len(junk)} junk bytes", lambda: path.write_bytes(junk)
            if kind == "utf-16":
                return f"{name}.txt in UTF-16", lambda: path.write_bytes(path.read_text().encode("utf-16"))
            if kind == "empty":
                return f"{name}.txt empty", lambda: path.write_text("")
            return f"{name}.txt missing", path.unlink
        if what == "few images":        # 2 or fewer left give too few training views
            gone = data.draw(st.integers(4, VIEWS), label="images gone")
            return f"{gone} of {VIEWS} images missing", lambda: [(ds / "images" / f"{k:04d}.png").unlink()
                                                                 for k in range(gone)]
        if what == "image":
            desc, fn = image_damage(data, ds / "images" / f"{i:04d}.png", (8, 8), others_in_split=True, may_go=False)
            return f"{i:04d}.png: {desc}", fn
        if what == "meta":
            return meta_damage(data, ds / "mitnerf.json")
        if binary:                       # the text damages below, written as the binary model's text twin
            shutil.rmtree(model)
            shutil.copytree(base["colmap"] / "sparse" / "0", model)
        if what == "camera":
            fx = float((model / "cameras.txt").read_text().splitlines()[1].split()[4])
            line = bad_camera(data, fx)
            return f"cameras.txt: {line!r}", text_line(model / "cameras.txt", 0, line)
        if what == "image line":
            line = bad_image(data, [t for t in (model / "images.txt").read_text().splitlines()
                                    if not t.startswith("#")][2 * i])
            return f"images.txt: {line!r}", text_line(model / "images.txt", 2 * i, line)
        line = data.draw(st.sampled_from(["1 0 0", "1 nan 0 0 128 128 128 0 1 0", "1 0 0 inf 128 128 128 0 1 0",
                                          "1 0 0 0 128 128 128 0 1", "1 x 0 0 128 128 128 0 1 0"]), label="point")
        return f"points3D.txt: {line!r}", text_line(model / "points3D.txt", 0, line)

    check_reader(f"reader: COLMAP ({'binary' if binary else 'text'})", data,
                 base["colmap_bin" if binary else "colmap"], damage)


@examples(1.0)
@given(data=st.data())
def test_idr_folders(base, data):
    """cameras_sphere.npz (its keys, shapes, values, scale and skew), the images and masks, mitnerf.json."""
    what = data.draw(st.sampled_from(["file", "key", "shape", "dtype", "value", "degenerate", "scale", "skew",
                                      "extra camera", "header", "image", "mask", "memory", "meta"]), label="what")
    i = data.draw(st.integers(0, VIEWS - 1), label="view")
    key = data.draw(st.sampled_from(["world_mat", "scale_mat"]), label="matrix") + f"_{i}"

    def damage(ds: Path):
        cam = ds / "cameras_sphere.npz"
        with np.load(cam) as z:
            a = {k: z[k] for k in z.files}
        if what == "file":
            return draw_file_damage(data, cam, "cameras_sphere.npz")
        if what == "key":
            desc = f"no {key}"
            a.pop(key)
        elif what == "shape":
            s = data.draw(st.sampled_from([(3, 3), (4,), (5, 5), (4, 4, 1), (2, 4)]), label="shape")
            desc, a[key] = f"{key} of shape {s}", np.resize(a[key], s)
        elif what == "dtype":
            t = data.draw(st.sampled_from(["U1", "complex64", "bool"]), label="dtype")
            desc, a[key] = f"{key} of {t}", np.zeros((4, 4), t)
        elif what == "value":
            r, c = data.draw(st.integers(0, 3), label="row"), data.draw(st.integers(0, 3), label="col")
            v = data.draw(st.sampled_from([NAN, INF, -INF]), label="value")
            a[key] = a[key].copy()
            desc, a[key][r, c] = f"{key}[{r}, {c}] = {v}", v
        elif what == "degenerate":
            desc, a[f"world_mat_{i}"] = "world_mat of rank 1", np.outer(a[f"world_mat_{i}"][:, 0], [1, 1, 1, 1])
        elif what == "scale":
            s = np.diag([1.0, 1.0, 1.0, 1.0])
            kind = data.draw(st.sampled_from(["stretched", "negative", "last row"]), label="scale damage")
            if kind == "stretched":
                s[1, 1] = data.draw(st.one_of(finite(0.01, 0.99), finite(1.01, 1e3)), label="y scale")
            elif kind == "negative":
                s[:3, :3] *= -data.draw(finite(0.01, 1e3), label="scale")
            else:
                s[3, data.draw(st.integers(0, 2), label="col")] = data.draw(away_from(0.0, 0.01), label="value")
            desc, a[f"scale_mat_{i}"] = f"scale_mat {kind}", s
        elif what == "skew":
            t = data.draw(away_from(0.0, 0.01, 100.0), label="skew")
            shear = np.eye(4)
            shear[0, 1] = t
            desc, a[f"world_mat_{i}"] = f"K skewed by {t:g}", shear @ a[f"world_mat_{i}"]
        elif what == "extra camera":
            desc, a[f"world_mat_{VIEWS}"], a[f"scale_mat_{VIEWS}"] = "a camera more", a["world_mat_0"], a["scale_mat_0"]
        elif what == "header":
            n = data.draw(st.integers(10 ** 6, 10 ** 12), label="rows")
            raw = npz_with_fake({k: v for k, v in a.items() if k != key}, {key: ((n, 4), np.float64)})
            return f"{key} header of {n} x 4", lambda: cam.write_bytes(raw)
        elif what == "image":
            desc, fn = image_damage(data, ds / "image" / f"{i:06d}.png", (8, 8), others_in_split=True)
            return f"image {i}: {desc}", fn
        elif what == "mask":
            desc, fn = image_damage(data, ds / "mask" / f"{i:06d}.png", (8, 8), others_in_split=True)
            return f"mask {i}: {desc}", fn
        elif what == "memory":
            side, n = too_many_pixels(data)

            def fn():
                mats = {f"{k}_{j}": a[f"{k}_0"] for j in range(n) for k in ("world_mat", "scale_mat")}
                cam.write_bytes(npz_bytes(**mats))
                for j in range(n):
                    for sub in ("image", "mask"):
                        (ds / sub / f"{j:06d}.png").write_bytes(png_header(side, side))
            return f"{n} views of {side} x {side} pixels", fn
        else:
            return meta_damage(data, ds / "mitnerf.json")
        return desc, lambda: cam.write_bytes(npz_bytes(**a))

    check_reader("reader: IDR / NeuS", data, base["idr"], damage)


def test_the_messages_name_the_file(base, tmp_path):
    """One hand-picked case per reader, read through the library: the message names the file and the fix."""
    from mitnerf.data.formats import load_dataset
    from mitnerf.errors import DataError

    for name, edit, words in [("llff", lambda d: np.save(d / "poses_bounds.npy", np.zeros((6, 15))), "poses_bounds"),
                              ("colmap", lambda d: (d / "sparse/0/cameras.txt").write_text("1 FOV 8 8 1 1 1 1 1\n"),
                               "image_undistorter"),
                              ("idr", lambda d: (d / "mask" / "000000.png").unlink(), "masks pair with images")]:
        shutil.copytree(base[name], tmp_path / name)
        edit(tmp_path / name)
        try:
            load_dataset(tmp_path / name)
        except DataError as exc:
            assert words in str(exc) and "\n" not in str(exc), show(str(exc))
        else:
            raise AssertionError(f"{name}: not refused")
