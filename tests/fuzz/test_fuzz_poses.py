"""Hostile inputs to ``mitnerf poses``: a folder of photographs that is missing, a file, empty, holds no images or
too few, a damaged image, images of two sizes or one too large, an output inside the photographs, and bad option
values. Each is refused before structure from motion starts (a valid case would run COLMAP and print its stages,
which fails the rule)."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, strategies as st

from .harness import case_dir, examples, MAX_SIDE, png, png_header, refused
from .strategies import draw_file_damage
from .test_fuzz_flags import as_args, draw_flag

PHOTOS = 3
"""Photographs in the valid folder (8 x 8 PNGs): the fewest `mitnerf poses` takes."""
POSES_FLAGS = {"--overlap": (True, 1, 10_000, False), "--max-image-size": (True, 64, 16384, False),
               "--max-features": (True, 100, 100_000, False), "--min-registered": (False, 0, 1, False),
               "--downscale": (True, 1, 64, False), "--seed": (True, 0, 2 ** 31 - 1, False)}


def photos(root: Path) -> Path:
    folder = root / "photos"
    folder.mkdir()
    for i in range(PHOTOS):
        (folder / f"{i}.png").write_bytes(png(8, 8, seed=i))
    return folder


@examples(1.0)
@given(data=st.data())
def test_poses_inputs(data):
    what = data.draw(st.sampled_from(["missing", "a file", "empty", "no images", "too few", "damaged", "other size",
                                      "too large", "out inside", "out is a file", "number", "choice"]), label="what")
    with case_dir() as t:
        folder, out, extra = photos(t), t / "data", []
        if what == "missing":
            folder = t / "nowhere"
        elif what == "a file":
            folder = folder / "0.png"
        elif what == "empty":
            for p in folder.iterdir():
                p.unlink()
        elif what == "no images":
            for p in folder.iterdir():
                p.rename(p.with_suffix(data.draw(st.sampled_from([".txt", ".npy", "", ".png.bak"]), label="suffix")))
            (folder / "notes").mkdir()
        elif what == "too few":
            for p in sorted(folder.iterdir())[data.draw(st.integers(0, PHOTOS - 1), label="left"):]:
                p.unlink()
        elif what == "damaged":
            img = folder / f"{data.draw(st.integers(0, PHOTOS - 1), label='image')}.png"
            what, damage = draw_file_damage(data, img, "png")
            damage()
        elif what == "other size":
            (folder / "1.png").write_bytes(png(*data.draw(st.sampled_from([(8, 9), (9, 8), (16, 16)]), label="hw")))
        elif what == "too large":
            side = data.draw(st.sampled_from([MAX_SIDE + 1, 10 ** 6]), label="side")
            (folder / "1.png").write_bytes(png_header(side, 8))
        elif what == "out inside":
            out = folder / data.draw(st.sampled_from(["data", "sub/data"]), label="out")
        elif what == "out is a file":
            out = folder / "0.png"
        elif what == "number":
            flag, value = draw_flag(data, POSES_FLAGS)
            extra, what = as_args(data, flag, value), f"{flag} {value!r}"
        else:
            flag = data.draw(st.sampled_from(["--matching", "--camera-model"]), label="flag")
            value = data.draw(st.sampled_from(["", "EXHAUSTIVE", "opencv", "FISHEYE", "OPENCV_FISHEYE", "vocab"]),
                              label="value")
            extra, what = as_args(data, flag, value), f"{flag} {value!r}"
        refused("poses: photograph folders and options", what, ["poses", "--images", folder, "--out", out, *extra],
                t, None if what == "out is a file" else out)
