"""Views held packed: the validation and test splits ``mitnerf fit`` renders against, compressed and unpacked a few
views at a time, give back exactly what they held."""

from __future__ import annotations

import numpy as np
import pytest

from mitnerf.data.cameras import Cameras
from mitnerf.data.dataset import Dataset, Split
from mitnerf.data.packed import Packed
from mitnerf.train.evaluate import evaluate
from mitnerf.train.recipes import get_recipe


def two_views() -> Split:
    """Two 8-bit views of 1 x 2 pixels: view 0 opaque red and half-covered white, view 1 empty and opaque grey."""
    rgb = np.array([[[[255, 0, 0], [255, 255, 255]]], [[[0, 0, 0], [128, 128, 128]]]], np.uint8)   # [2, 1, 2, 3]
    alpha = np.array([[[255, 128]], [[0, 255]]], np.uint8)                                           # [2, 1, 2]
    return Split(Cameras(np.stack([np.eye(4)] * 2), 2.0, 1, 2), rgb, alpha)


def test_packed_views_unpack_to_what_they_held():
    split = two_views()
    packed = split.packed()
    assert packed.is_packed and packed.eight_bit and not split.is_packed
    # view 0 over white: red (1, 0, 0); white at alpha 128/255 is white again: (1, 1, 1)
    np.testing.assert_array_equal(packed.target((1, 1, 1), views=[0])[0], [[[1, 0, 0], [1, 1, 1]]])
    # view 1 over black: empty -> 0; grey 128/255 = 0.50196
    np.testing.assert_allclose(packed.target(views=1), [[[0, 0, 0], [128 / 255] * 3]], rtol=0, atol=1e-7)
    np.testing.assert_array_equal(packed.color, split.color)
    np.testing.assert_array_equal(packed.alpha, split.alpha)
    assert packed.has_alpha and split.has_alpha
    one = packed.subset([1])                                  # stays packed; only view 1's stream is kept
    assert one.is_packed and len(one) == 1
    np.testing.assert_array_equal(one.alpha, [[[0.0, 1.0]]])
    index = np.array([0, 3, 2])                                # flat pixel indices, as a training batch draws them
    for a, b in zip(packed.pixels(index), split.pixels(index)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(packed.covered(index), [True, True, False])
    both = Split.concatenate([packed, split])
    np.testing.assert_array_equal(both.target(views=[2]), split.target(views=[0]))


def test_what_is_packed_and_what_is_not():
    floats = Split(Cameras(np.eye(4)[None], 2.0, 1, 2), np.full((1, 1, 2, 3), 0.3, np.float32),
                   np.ones((1, 1, 2), np.float32))
    assert floats.packed() is floats                           # 0.3 is no 8-bit value: held as floats
    opaque = Split(floats.cameras, np.full((1, 1, 2, 3), 7, np.uint8), np.full((1, 1, 2), 255, np.uint8)).packed()
    assert opaque.is_packed and not opaque.has_alpha          # all ones: a format without alpha
    plain = np.zeros((1, 64, 64, 3), np.uint8), np.full((1, 64, 64), 255, np.uint8)
    assert Packed.of(*plain).nbytes < 64 * 64 * 4 / 20         # a plain view shrinks
    with pytest.raises(Exception, match="alpha=None"):
        Split(floats.cameras, Packed.of(np.zeros((1, 1, 2, 3), np.uint8), np.zeros((1, 1, 2), np.uint8)),
              np.ones((1, 1, 2), np.float32))


def test_a_packed_test_split_scores_what_the_held_one_does(vase_small, tmp_path):
    """A Blender folder of 8-bit images: evaluated packed, its test views give the same PSNR and SSIM to the last
    bit; ``mitnerf fit``'s reader holds every split but the training one packed."""
    from mitnerf.cli.fit_cmd import read_views
    from mitnerf.data.formats import load_dataset, save_dataset

    save_dataset(vase_small, tmp_path / "ds", "blender")
    for f in (tmp_path / "ds").rglob("*_linear.npy"):          # 8-bit PNG colours only, as a Blender scene
        f.unlink()
    ds = load_dataset(tmp_path / "ds")
    held, said = read_views(str(tmp_path / "ds"), None)
    assert said is None and [held[s].is_packed for s in ("train", "val", "test")] == [False, True, True]

    class Grey:                    # a trained model stand-in: every ray renders grey 0.4 at opacity 0.7
        model_cfg, bound = get_recipe("grid-3d").model, 1.0

        def render(self, origins, directions, chunk=None, footprint=None, spp=1):
            n = len(origins)
            return {"rgb": np.full((n, 3), 0.4, np.float32), "depth": np.ones(n, np.float32),
                    "opacity": np.full(n, 0.7, np.float32)}

        def n_params(self):
            return 0

    a, b = (evaluate(Grey(), d, geometry_metrics=False) for d in (ds, held))
    assert (a.psnr, a.ssim) == (b.psnr, b.ssim) and 0 < a.psnr < 30
    assert Dataset.packed(ds)["train"] is ds["train"]
