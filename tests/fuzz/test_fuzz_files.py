"""Hostile polygon files and Mitsuba XML scenes."""

from __future__ import annotations

import math
import string

import numpy as np
from hypothesis import given, strategies as st

from .harness import case_dir, examples, refused, XML
from .strategies import draw_json_damage, dumps, finite, NON_FINITE, show


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
    kind = data.draw(st.sampled_from(["pixel units", "self-intersecting", "few points", "non-finite", "strings", "nested",
                                      "repeated vertex", "collinear", "json", "not points", "name", "too many"]),
                     label="kind")
    k = data.draw(st.integers(4, 9), label="points")
    pts = ring(data, k)
    wrap = data.draw(st.booleans(), label="as object")
    name = None
    if kind == "pixel units":                   # an outline far outside the unit frame (an open one is closed)
        scale = data.draw(st.sampled_from([10.0, 100.0, 400.0]), label="scale")
        pts = [[x * scale, y * scale] for x, y in pts] if data.draw(st.booleans(), label="closed") else \
            [[x * scale, y * scale] for x, y in pts[:-1]]
        desc = f"ring of {k} points at {scale:g} times the unit frame"
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
                                                      "--val", "0", "--test", "1", "--image-size", "4", "--spp", "1"],
                t, out)


# ------------------------------------------------------------------------------ Mitsuba XML


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
        argv = ["dataset", "--scene", f, "--out", out, "--views", "1", "--val", "0", "--test", "1", "--image-size",
                "4", "--spp", "1"]
        refused("Mitsuba XML files", f"{kind}: {desc}", argv, t, out)
