"""Bad numbers on the command line of every command: out of range, not finite, not a number."""

from __future__ import annotations

import string

from hypothesis import given, strategies as st

from .harness import case_dir, examples, refused
from .strategies import finite


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
             "--fine": (True, 0, 4096, False), "--mlp-width": (True, 2, 1024, False), "--mlp-depth": (True, 1, 32, False),
             "--pos-L": (True, 0, 24, False), "--dir-L": (True, 0, 12, False),
             "--grid-resolution": (True, 2, 8193, False), "--sh-degree": (True, 1, 8, False)}
DATASET_FLAGS = {"--views": (True, 0, 100_000, False, ["0"]), "--val": (True, 0, 100_000, False),
                 "--test": (True, 0, 100_000, False), "--image-size": (True, 0, 16384, False, ["0"]),
                 "--radius": (False, 0, 1e4, True), "--fov": (False, 0, 179, True), "--noise": (False, 0, 100, False),
                 "--radius-std": (False, 0, 1e4, False), "--angle-std": (False, 0, 1e4, False),
                 "--position-std": (False, 0, 1e4, False), "--look-std": (False, 0, 1e4, False),
                 "--spp": (True, 1, 1 << 16, False), "--seed": (True, 0, 2 ** 32 - 1, False)}
VIDEO_FLAGS = {"--frames": (True, 1, 100_000, False), "--image-size": (True, 1, 4096, False, ["1"]),
               "--elevation": (False, -90, 90, False, ["89.95", "-89.95", "90", "-90"]),
               "--radius": (False, 0, 1e4, True), "--fov": (False, 0, 179, True), "--fps": (False, 0, 1000, True),
               "--mesh-resolution": (True, 2, 1024, False)}
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
                 "--backend": ["drjit", "torch"], "--background": ["black", "white", "random"]}[flag]
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
                "--image-size", "4", "--spp", "1", *as_args(data, flag, value)]
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
        argv = ["video", "--checkpoint", base["ckpt3"], "--out", out, "--frames", "2", "--image-size", "4",
                "--mesh-resolution", "8", "--level", "auto", *as_args(data, flag, value)]
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
                                                     "2", "--image-size", "4", "--mesh-resolution", "8", "--level",
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
