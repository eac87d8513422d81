"""Hostile NeRF2D folders (ours and the original add-on's), and the valid inputs in unicode
paths with spaces: each case breaks one thing and must be refused by the rule of
:mod:`harness`."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from hypothesis import given, strategies as st

from .harness import case_dir, examples, ring_points, run_main, XML
from .strategies import bad_focal, draw_frames_damage, draw_json_damage, edit_json, show
from .readers import check_reader, image_damage, meta_damage, NERF2D_COUNTS, npz_damage


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
        rc, stdout, err, _ = run_main(["fit", "--data", tiny, "--iters", "1", "--no-figures", "--out", t / "tïny ✓ run"])
        assert rc == 0, err
        (t / "szène ✓.xml").write_text(XML.format(ply=base["ply"]))
        (t / "öutline ✓.json").write_text(json.dumps({"name": "fuzz ✓", "points": ring_points(6)}))
        for flag, f in (("--scene", "szène ✓.xml"), ("--polygon", "öutline ✓.json")):
            rc, stdout, err, _ = run_main(["dataset", flag, t / f, "--out", t / f"dätä {flag}", "--views", "1",
                                           "--val", "0", "--test", "1", "--image-size", "4", "--spp", "1"])
            assert rc == 0, err
        rc, stdout, err, _ = run_main(["video", "--checkpoint", base["ckpt3"], "--out", t / "vïdeo ✓", "--frames",
                                       "2", "--image-size", "4", "--mesh-resolution", "8",
                                       "--level", "auto"])
        assert rc == 0, err
    from mitnerf.data.formats import load_dataset

    for name in ("nerf2d", "addon", "blender", "nerfstudio3", "nerfstudio2", "ngp", "tiny", "llff", "colmap",
                 "colmap_bin", "idr"):
        ds = load_dataset(base[name])
        assert {"train", "test"} <= set(ds.splits), name


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
