"""Hostile checkpoints (hand-edited manifests, damaged arrays) for ``video`` and ``fit
--resume``; fixed cases (memory estimates, a newer format); the real stderr of a subprocess."""

from __future__ import annotations

import json
import shutil
import string
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from .harness import case_dir, CASES, examples, INF, NAN, npz_bytes, refused, ROOT, XML
from .strategies import draw_file_damage, draw_json_damage, edit_json, finite, NON_FINITE, show, WRONG_TYPE_OR_NULL


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
        (ck / f).write_bytes(npz_bytes(**arrays))
        if consistent:
            from mitnerf.train.checkpoint import _write_npz

            listed[f] = _write_npz(ck / f, arrays)
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
                                                  ["--auto"], ["--set", "lr=0.1"], ["--samples", "8"],
                                                  ["--out", "elsewhere"]]), label="flag")
                desc, fn = f"--resume with {' '.join(flag)}", lambda: None
        fn()
        out = t / "video"
        if cmd.startswith("video"):
            argv = ["video", "--checkpoint", ck, "--out", out, "--frames", "2", "--image-size", "4",
                    "--mesh-resolution", "8", "--level", "auto"]
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
            line = refused("fixed cases", case, ["dataset", "--scene", "vase", "--views", "100000", "--image-size",
                                                 "16384", "--out", out], t, out)
            assert "GiB" in line
        else:
            line = refused("fixed cases", case, ["video", "--checkpoint", base["ckpt3"], "--frames", "100000",
                                                 "--image-size", "4096", "--out", out], t, out)
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
