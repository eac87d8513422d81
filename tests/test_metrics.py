"""The image metrics against hand computations and scikit-image."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.metrics import structural_similarity

from mitnerf.train.metrics import psnr, ssim


def test_psnr_by_hand():
    # one channel off by 0.1 on every pixel: MSE 0.01 / 3, PSNR -10 log10(0.003333) = 24.771 dB
    t = np.zeros((1, 4, 4, 3), np.float32)
    p = t.copy()
    p[..., 0] = 0.1
    assert psnr(p, t) == pytest.approx(24.7712, abs=1e-4)


def test_ssim_of_flat_views_by_hand():
    # flat grey 0.5 against flat white: the variances are 0, so SSIM is its luminance term alone,
    # (2 * 0.5 * 1 + C1) / (0.25 + 1 + C1) with C1 = 0.01^2: 0.80003
    assert ssim(np.full((1, 9, 9, 3), 0.5, np.float32), np.ones((1, 9, 9, 3), np.float32)) == pytest.approx(
        (1 + 1e-4) / (1.25 + 1e-4), abs=1e-6)


def test_ssim_refuses_views_narrower_than_its_smallest_window():
    from mitnerf.errors import MitnerfError

    with pytest.raises(MitnerfError, match="at least 3 pixels along each axis"):
        ssim(np.zeros((1, 2, 8, 3), np.float32), np.zeros((1, 2, 8, 3), np.float32))


@pytest.mark.parametrize("shape", [(2, 40, 30, 3), (1, 5, 6, 3), (1, 25, 1, 3)])
def test_ssim_is_scikit_images(shape):
    """Noisy renders of random views, 2D views of 7 pixels and more, of fewer (a smaller window) and 1D views: the
    figure scikit-image gives, channel by channel, to float32's rounding."""
    rng = np.random.default_rng(4)
    t = rng.random(shape, dtype=np.float32)
    p = t + 0.2 * rng.standard_normal(shape).astype(np.float32)          # values outside [0, 1] are clipped
    want = []
    for a, b in zip(np.clip(p, 0, 1), t):
        a, b = (a[:, 0], b[:, 0]) if shape[2] == 1 else (a, b)
        win = max(3, min(7, *[s if s % 2 else s - 1 for s in a.shape[:-1]]))
        want.append(structural_similarity(a, b, channel_axis=-1, data_range=1.0, win_size=win))
    assert ssim(p, t) == pytest.approx(np.mean(want), abs=1e-6)


def test_peak_memory_is_the_programs_own_not_its_parents():
    """A process started by a large one reports its own peak: ``getrusage`` would carry over the parent's size
    (here above 0.5 GiB, its array touched) through fork and exec."""
    import subprocess
    import sys

    held = np.ones(160 * 2 ** 20, np.float32)             # 640 MiB resident in this process
    child = subprocess.run([sys.executable, "-c", "from mitnerf.train.evaluate import peak_memory; "
                            "print(peak_memory())"], capture_output=True, text=True, check=True)
    assert held.sum() > 0 and float(child.stdout) < 0.4
