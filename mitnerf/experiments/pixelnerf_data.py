"""Data of the 2D pixelNeRF experiment: procedural outlines, per-scene view sets, sparse subsets.

* :func:`random_outline`: a seeded, star-shaped random polygon (MNIST1D-style: a few
  radial harmonics plus per-vertex noise, 6 to 40 vertices, random turn), so that the
  colour cycle along the outline starts at a random angle.
* :func:`outline_scene`: its Mitsuba scene, with the four point lights at a random
  radius in [3.0, 3.5] and intensity in [9, 12] (the named 2D scenes use 3.0-3.5 and
  9-12), so lighting is not a give-away of the training set.
* :func:`outline_dataset`: train views (random, noisy) and test views (even, noise-free)
  of one outline, rendered with :func:`mitnerf.data.generate.make_dataset`. Rendering a
  2D outline takes ~50 ms, less than reading it back from disk, so outlines are not cached;
  the named scenes go through :func:`mitnerf.experiments.common.cached_dataset`.
* :class:`SceneViews`: one scene's views as flat numpy arrays for the trainer.
* :func:`pick_views`: ``k`` of a split's cameras spread as evenly around the circle as the
  split allows (the sparse-view inputs shared by pixelNeRF and the NeRF baselines).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..data.cameras import Cameras
from ..data.dataset import Dataset
from ..data.rig import RigConfig, noise_preset
from ..scenes.polygon import Polygon
from ..scenes.registry import SceneInfo, scene_2d


def random_outline(seed: int, max_radius: tuple = (1.0, 1.6)) -> Polygon:
    """A star-shaped random outline (simple by construction: strictly increasing angles,
    positive radii). Its largest radius is drawn from ``max_radius``."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(6, 41))
    turn = rng.uniform(0, 2 * np.pi)
    angle = turn + 2 * np.pi * (np.arange(n) + rng.uniform(-0.35, 0.35, n)) / n     # sorted, gaps < pi
    m = np.arange(1, 5)
    amp = rng.uniform(0, 1, 4) * 0.35 / m
    phase = rng.uniform(0, 2 * np.pi, 4)
    noise = rng.choice([0.02, 0.08, 0.2])
    r = 1 + (amp[:, None] * np.cos(m[:, None] * angle[None] + phase[:, None])).sum(0) + noise * rng.standard_normal(n)
    r = np.maximum(r, 0.3)
    r = r / r.max() * rng.uniform(*max_radius)
    pts = np.stack([r * np.cos(angle), r * np.sin(angle)], 1)
    return Polygon.from_points(np.r_[pts, pts[:1]], f"outline{seed}")


def outline_scene(seed: int) -> SceneInfo:
    """The scene of :func:`random_outline` ``(seed)``, with randomised lights."""
    rng = np.random.default_rng([seed, 1])
    info = scene_2d(random_outline(seed))
    lights = {"light_radius": f"{rng.uniform(3.0, 3.5):.4f}", "light_intensity": f"{rng.uniform(9.0, 12.0):.4f}"}
    return dataclasses.replace(info, variables={**info.variables, **lights})


def outline_rig(n_train: int, n_test: int, seed: int) -> RigConfig:
    """The rig of every scene in the experiment: NeRF2D's radius-4 circle, 100 px, noisy."""
    return RigConfig(dim=2, n_train=n_train, n_val=0, n_test=n_test, resolution=100, seed=seed, **noise_preset(1.0))


def outline_dataset(seed: int, n_train: int, n_test: int) -> Dataset:
    from ..data.generate import make_dataset

    return make_dataset(outline_scene(seed), outline_rig(n_train, n_test, seed), progress=False)


@dataclass
class SceneViews:
    """The views of one split of one scene, as numpy arrays."""

    name: str
    images: np.ndarray
    """Colours over the background ``[V, H, 3]``."""
    poses: np.ndarray
    """Camera-to-world ``[V, 3, 3]``."""
    focal: float
    origins: np.ndarray
    """Pixel-centre rays ``[V, H, 2]``."""
    directions: np.ndarray
    """Unit directions ``[V, H, 2]``."""
    near: float
    far: float
    features: np.ndarray | None = None
    """Frozen-encoder features ``[F, V*H]``, filled in by the trainer when it needs them."""
    features_key: tuple | None = None
    """The encoder that made ``features`` (:attr:`PixelNeRFConfig.encoder_key`)."""

    @property
    def n_views(self) -> int:
        return len(self.poses)

    @property
    def height(self) -> int:
        return self.images.shape[1]

    def feature_columns(self, views: np.ndarray) -> np.ndarray:
        """Frozen features of some views ``[F, len(views)*H]`` (view-major)."""
        H = self.height
        cols = (np.asarray(views)[:, None] * H + np.arange(H)[None]).ravel()
        return self.features[:, cols]


def scene_views(dataset: Dataset, split: str = "train", name: str | None = None) -> SceneViews:
    s = dataset[split]
    o, d = s.cameras.rays()
    return SceneViews(name or str(dataset.meta.get("scene", "scene")), s.target(dataset.background)[:, :, 0, :],
                      s.cameras.poses, float(s.cameras.focal), o[:, :, 0, :].astype(np.float32),
                      d[:, :, 0, :].astype(np.float32), float(dataset.near), float(dataset.far))


def pick_views(cameras: Cameras, k: int) -> np.ndarray:
    """Indices of ``k`` cameras whose angles around the origin are nearest to ``k`` evenly
    spaced angles starting at camera 0's (each camera used once)."""
    pos = cameras.origins
    ang = np.arctan2(pos[:, 1], pos[:, 0])
    goals = ang[0] + 2 * np.pi * np.arange(k) / k
    free = np.ones(len(ang), bool)
    out = []
    for g in goals:
        dist = np.abs((ang - g + np.pi) % (2 * np.pi) - np.pi)
        dist[~free] = np.inf
        j = int(np.argmin(dist))
        free[j] = False
        out.append(j)
    return np.array(out)


