"""Training a 2D pixelNeRF across scenes (with the one loop), and rendering it from a few views. A step
picks, from its seed, a scene, ``k`` in ``k_range`` of its views as the context and ``batch_rays`` target
rays from its *other* views. Shapes change with ``k``, so steps are traced, not frozen."""

from __future__ import annotations

from dataclasses import dataclass, replace

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32
from drjit.opt import Adam

from .._drjit_compat import set_learning_rate
from ..data.cameras import Cameras
from ..data.dataset import Dataset
from ..errors import ConfigError
from ..fields.pixelnerf import Context, PixelNeRFConfig, PixelNeRFField, make_context
from ..render.samplers import Stratified
from ..render.volume import volume_render
from .backend_drjit import columns
from .losses import mse
from .loop import LoopState, run_loop
from .recipes import Recipe


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
    """Frozen-encoder features ``[F, V*H]``, computed once when needed."""

    @property
    def n_views(self) -> int:
        return len(self.poses)

    def context(self, field: PixelNeRFField, views) -> Context:
        """The context made of some of these views (frozen features reused)."""
        views = np.asarray(views)
        feats = None
        if field.frozen is not None:
            if self.features is None:
                self.features = field.features_numpy(self.images)
            H = self.images.shape[1]
            feats = self.features[:, (views[:, None] * H + np.arange(H)[None]).ravel()]
        return make_context(self.images[views], self.poses[views], self.focal, feats)


def scene_views(dataset: Dataset, split: str = "train", name: str | None = None) -> SceneViews:
    s = dataset[split]
    o, d = s.cameras.rays()
    return SceneViews(name or str(dataset.meta.get("scene", "scene")), s.target(dataset.background)[:, :, 0, :],
                      s.cameras.poses, float(s.cameras.focal), o[:, :, 0, :].astype(np.float32),
                      d[:, :, 0, :].astype(np.float32), float(dataset.near), float(dataset.far))


def pick_views(cameras: Cameras, k: int, start: int = 0) -> np.ndarray:
    """Indices of ``k`` cameras whose angles around the origin are nearest to ``k`` evenly
    spaced angles starting at camera ``start``'s (each camera used once)."""
    ang = np.arctan2(cameras.origins[:, 1], cameras.origins[:, 0])
    out: list[int] = []
    for g in ang[start] + 2 * np.pi * np.arange(k) / k:
        dist = np.abs((ang - g + np.pi) % (2 * np.pi) - np.pi)
        dist[out] = np.inf
        out.append(int(np.argmin(dist)))
    return np.array(out)


class PixelTrainer:
    """A pixelNeRF field, its Adam, and the step function of the loop."""

    def __init__(self, field_cfg: PixelNeRFConfig, recipe: Recipe, scenes: list[SceneViews], k_range: tuple):
        short = [s.name for s in scenes if s.n_views <= k_range[1]]
        if short:
            raise ConfigError(f"scenes {short} have at most {k_range[1]} views; give each more views than "
                              f"k_range's maximum ({k_range[1]}) or lower it")
        self.recipe, self.scenes, self.k_range = recipe, scenes, k_range
        dr.set_thread_count(recipe.train.threads)
        self.field = PixelNeRFField(field_cfg)
        self.opt = Adam(lr=recipe.train.lr, params=self.field.init_params(recipe.train.seed))
        self.state = LoopState()

    @property
    def params(self) -> dict:
        return {k: dr.detach(self.opt[k]) for k in self.opt.keys()}

    def step(self, index: int, seed: int, lr: float):
        rng = np.random.default_rng(seed)
        B, n = self.recipe.train.batch_rays, self.recipe.model.render.n_coarse
        sc = self.scenes[rng.integers(len(self.scenes))]
        k = int(rng.integers(self.k_range[0], self.k_range[1] + 1))
        perm = rng.permutation(sc.n_views)
        view, pix = rng.choice(perm[k:], B), rng.integers(0, sc.images.shape[1], B)
        fld = self.field.with_context(sc.context(self.field, perm[:k]))
        opt = self.opt
        set_learning_rate(opt, dr.opaque(Float, lr))
        params = {name: opt[name] for name in opt.keys()}
        out = volume_render(fld, params, columns(sc.origins[view, pix]), columns(sc.directions[view, pix]),
                            dr.opaque(Float, sc.near), dr.opaque(Float, sc.far),
                            Stratified(n, dr.opaque(UInt32, seed), jitter=True), (0.0, 0.0, 0.0),
                            w_min=self.recipe.model.render.min_color_weight)
        loss = mse(out.rgb, columns(sc.images[view, pix]))
        dr.backward(loss)
        opt.step()
        return loss

    @staticmethod
    def read(loss) -> tuple[float, str | None]:
        return float(loss[0]), None

    def train(self) -> "PixelTrainer":
        run_loop(self.step, self.read, self.recipe.train, self.state, desc=f"pixelNeRF ({self.field.cfg.encoder})")
        return self

    def render(self, context: Context, origins: np.ndarray, directions: np.ndarray, near: float, far: float,
               chunk: int = 512) -> dict:
        """Rays ``[P, 2]`` seen through ``context`` -> numpy ``rgb [P, 3]``, ``depth``, ``opacity``."""
        params, n = self.params, self.recipe.model.render.n_coarse
        fld = self.field.with_context(context)
        parts = []
        with dr.suspend_grad():
            if context.features is None:      # encode the context once, not per chunk
                fld.context = replace(context, features=fld.features(params, context))
            for s in range(0, len(origins), chunk):
                out = volume_render(fld, params, columns(origins[s:s + chunk]), columns(directions[s:s + chunk]),
                                    dr.opaque(Float, near), dr.opaque(Float, far),
                                    Stratified(n, UInt32(0), jitter=False), (0.0, 0.0, 0.0),
                                    w_min=self.recipe.model.render.min_color_weight)
                dr.eval(out.rgb, out.depth, out.opacity)
                parts.append((np.stack([np.asarray(c) for c in out.rgb], 1), np.asarray(out.depth),
                              np.asarray(out.opacity)))
        return {k: np.concatenate([p[i] for p in parts]) for i, k in enumerate(("rgb", "depth", "opacity"))}

    def density(self, context: Context):
        """``points [m, 2] -> density [m]`` of the field conditioned on ``context``."""
        fld, params = self.field.with_context(context), self.params

        def fn(pts: np.ndarray) -> np.ndarray:
            with dr.suspend_grad():
                return np.concatenate([np.asarray(fld.density(params, columns(pts[s:s + 4096])))
                                       for s in range(0, len(pts), 4096)])
        return fn
