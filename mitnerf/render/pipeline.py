"""A NeRF model: fields plus how to render them (a coarse pass, an optional fine pass, as NeRF).

Parameters of all fields live in one flat dict with prefixed keys (``coarse.mlp``, ``fine.trunk.0.weight``,
...), which is what an optimizer holds. Twin: :mod:`mitnerf.reference.render.pipeline`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import drjit as dr
from drjit.auto.ad import Float, UInt32

from ..data.rays import BACKGROUNDS
from ..errors import ConfigError
from ..settings import check, parse_color, setting
from .integral import W_MIN, RenderOutput
from .occupancy import OccupancyConfig, OccupiedSampler
from .samplers import Stratified, importance_sample
from .space import SCENES, Space, check_frame
from .volume import METHODS, volume_render


@dataclass
class RenderConfig:
    """How rays are sampled and integrated."""

    n_coarse: int = setting(64, lo=1, hi=4096, flag="--samples", unit="per ray")
    """Samples per ray (stratified, or placed in occupied space by the occupancy grid)."""
    n_fine: int = setting(0, lo=0, hi=4096, flag="--fine", unit="per ray")
    """Importance samples per ray drawn from the coarse weights (0: no fine pass)."""
    separate_fine: bool = setting(True)
    """Give the fine pass its own field (NeRF); otherwise the coarse field is reused."""
    background: str | tuple | None = setting(None, lo=0, hi=1, flag="--background", parse=lambda text: parse_color(
        text, ("white", "black", "random")), metavar="white|black|random|R,G,B", shown="the dataset's")
    """Colour behind the object: white, black, random or r,g,b; unset: the dataset's own
    (:attr:`~mitnerf.data.dataset.Dataset.background`: white for Blender-synthetic folders and our 3D objects, black
    for 2D and tiny-NeRF files), which ``fit`` writes here. ``random`` draws a uniform colour per training ray, as
    instant-ngp does, so the field cannot paint the background into empty space; renders and evaluation are then
    over white."""
    method: str = setting("replay", choices=METHODS, flag="--method")
    """Volume integral: ``replay`` (the custom operation) or ``autodiff`` (plain AD, the check)."""
    occupancy: OccupancyConfig = field(default_factory=OccupancyConfig)
    """Empty-space skipping: an occupancy grid places the coarse samples (``n_coarse``)."""
    pixel_jitter: bool = setting(False)
    """Train on rays spread over each pixel's footprint (its ground truth: the footprint's average)."""
    eval_spp: int = setting(1, lo=1, hi=64)
    """Rays averaged per pixel when evaluating (stratified over the footprint: 2D along the
    view, 3D on a square grid); 1: the pixel centre."""
    render_oversample: int = setting(1, lo=1, hi=16)
    """Coarse samples per ray multiplied by this when a trained field is rendered (evaluation, videos), not in
    training: where a ray crosses more occupied bins than it has samples, a quadrature finer than the one the field
    was fitted with, so its renders do not show where the training samples fell (``benchmarks/lego.py``). The
    occupancy bins stay ``march_bins`` (their lookups are a large share of a render's work, and a ray never has more
    samples than occupied bins), the fine pass keeps ``n_fine``; pixelNeRF's renderer takes ``n_coarse`` as it is."""
    defer_color: bool = setting(True)
    """Renders without gradients march the density alone and read the colour of the samples that keep some
    afterwards, packed (:mod:`.deferred`): the same renders, faster where the colour is many reads (the dense grid's
    view harmonics), for one float a sample slot more memory; False: the fused march (``benchmarks/render.py``)."""
    min_color_weight: float = setting(W_MIN, lo=0.0, hi=0.01)
    """Samples whose weight is at most this add no colour, and the dense grid reads no colour there
    (:mod:`.integral`); 0: the colour of every sample of positive weight counts."""
    scene: str = setting("auto", choices=("auto", *SCENES), flag="--scene-type")
    """What the data shows: an object in a box, a forward-facing capture (rendered in NDC, as NeRF's LLFF scenes)
    or an unbounded one (a room around the object, in mip-NeRF 360's contracted space); auto: chosen from the
    data's alpha and its cameras' layout when a fit starts, and said (``mitnerf.render.space``)."""
    frame: dict = field(default_factory=dict)
    """A forward-facing or unbounded scene's frame, derived from the cameras when a fit starts (the map from world
    to the warped space, the fields' half-extent there, near, far and the samples' knee:
    ``mitnerf.render.space.scene_frame``); empty: not derived yet."""

    def __post_init__(self):
        if isinstance(self.background, list):
            self.background = tuple(self.background)
        if isinstance(self.occupancy, dict):
            self.occupancy = OccupancyConfig(**self.occupancy)

    def validate(self) -> None:
        check(self)
        bg = self.background
        if isinstance(bg, tuple) and len(bg) != 3:
            raise ConfigError(f"--background needs 3 values (r, g, b), got {bg!r}")
        if isinstance(bg, str) and bg not in ("random", *BACKGROUNDS):
            raise ConfigError(f"--background must be white, black, random or r,g,b; got {bg[:40]!r}")
        if self.frame:
            check_frame(self.frame)

    def render_background(self) -> tuple:
        """The constant colour renders are composited over: ``random``'s is white, an unresolved one (None) black."""
        bg = self.background
        return BACKGROUNDS["white" if bg == "random" else bg or "black"] if not isinstance(bg, tuple) else bg

    @property
    def space(self) -> Space:
        """The scene's space (a scene still ``auto`` renders as an object in a box)."""
        if self.scene in ("auto", "object"):
            return Space()
        if not self.frame:
            raise ConfigError(f"a {self.scene} scene needs its frame: fit derives it from the cameras")
        return Space(self.scene, self.frame)


def split_params(params: dict, prefix: str) -> dict:
    p = prefix + "."
    return {k[len(p):]: v for k, v in params.items() if k.startswith(p)}


def join_params(**groups: dict) -> dict:
    return {f"{g}.{k}": v for g, sub in groups.items() for k, v in sub.items()}


class FieldSet:
    """What a model of either engine (this one, its torch twin) knows of its ``fields``."""

    @property
    def dim(self) -> int:
        return self.fields["coarse"].dim

    def final_field(self) -> str:
        """The field whose output is the model's answer (fine if present)."""
        return "fine" if "fine" in self.fields else "coarse"


@dataclass
class Model(FieldSet):
    """Fields and a render configuration."""

    fields: dict
    """``{'coarse': field}`` and, with a separate fine pass, ``'fine'``."""
    render_cfg: RenderConfig = field(default_factory=RenderConfig)

    def saved(self, key: str, values):
        """Values in the layout of storage array ``key`` (``group.name``) as a checkpoint keeps them
        (:meth:`~mitnerf.fields.base.Field.saved`)."""
        group, name = key.split(".", 1)
        return self.fields[group].saved(name, values)

    def stored(self, key: str, values):
        """:meth:`saved`'s values back in storage array ``key``'s layout (:meth:`~mitnerf.fields.base.Field.stored`)."""
        group, name = key.split(".", 1)
        return self.fields[group].stored(name, values)

    def init_numpy(self, seed: int) -> dict:
        """Initial weights, canonical numpy (both engines start from these)."""
        return join_params(**{name: f.init_numpy(seed + k) for k, (name, f) in enumerate(self.fields.items())})

    def init_params(self, seed: int) -> dict:
        return self.from_numpy(self.init_numpy(seed))

    def to_numpy(self, params: dict) -> dict:
        return join_params(**{g: f.to_numpy(split_params(params, g)) for g, f in self.fields.items()})

    def from_numpy(self, arrays: dict) -> dict:
        return join_params(**{g: f.from_numpy(split_params(arrays, g)) for g, f in self.fields.items()})

    def schedule(self, step: int, params: dict) -> dict | None:
        """Parameters that a field's training schedule replaces before ``step`` (e.g. a
        grid's coarse-to-fine resize), with prefixed keys; None when nothing changes."""
        return join_params(**{g: f.schedule(step, split_params(params, g)) or {}
                              for g, f in self.fields.items()}) or None

    def at_step(self, params: dict, step) -> dict:
        """``params`` with the training step (a Float; None: training is over) under each field's ``step`` key: what
        a field's step-dependent schedule reads (:attr:`~mitnerf.fields.mlp.NeRFConfig.pe_window`)."""
        return params if step is None else {**params, **{f"{g}.step": step for g in self.fields}}

    def regularizer(self, params: dict, seed: UInt32):
        """Sum of the fields' regularisers (e.g. total variation), or None."""
        return sum_terms(f.regularizer(split_params(params, g), seed) for g, f in self.fields.items())

    def density(self, params: dict, x) -> Float:
        g = self.final_field()
        return self.fields[g].density(split_params(params, g), x)

    def render(self, params: dict, origins: list, directions: list, near, far, seed: UInt32,
               training: bool, weights: bool = False, input_grads: bool = False,
               occupancy: tuple | None = None, background: list | None = None) -> dict:
        """-> ``{'coarse': RenderOutput, 'fine': RenderOutput or None}``, plus
        ``'samples': (t, delta)`` of the final pass and ``'spacing'``, the same along the distortion loss's
        coordinate (:meth:`~.space.Space.spacing`), when ``weights`` is set;
        ``occupancy``: the occupancy grid's
        :attr:`~.occupancy.OccupancyGrid.lookup`; ``background``: 3 arrays ``[n]``, a colour per ray (training), else
        the configuration's (:meth:`RenderConfig.render_background`). Renders without training end each ray's
        march where its transmittance falls to ``min_color_weight`` (:mod:`.integral`)."""
        cfg, space = self.render_cfg, self.render_cfg.space
        bg = tuple(background) if background is not None else cfg.render_background()
        n = dr.width(origins[0])
        near, far = Float(near), Float(far)
        f = 1 if training else cfg.render_oversample
        n_coarse = cfg.n_coarse * f
        if occupancy is None or not cfg.occupancy.enabled:
            sampler = Stratified(n_coarse, seed, jitter=training, knee=space.knee)
        else:
            coarse = self.fields["coarse"]
            early_stop = cfg.occupancy.early_stop if training and coarse.traceable else 0.0
            density = None
            if early_stop > 0.0:
                p = {k: dr.detach(v) for k, v in split_params(params, "coarse").items()}
                density = lambda x: coarse.density(p, x)                                    # noqa: E731
            sampler = OccupiedSampler(*occupancy, n_coarse, cfg.occupancy.march_bins, coarse.bound,
                                      cfg.occupancy.resolution, seed, jitter=training, space=space, density=density,
                                      early_stop=early_stop, grouped=training,
                                      fill=training).build(origins, directions, near, far)
        kw = dict(method=cfg.method, input_grads=input_grads, w_min=cfg.min_color_weight,
                  stop=0.0 if training else cfg.min_color_weight, space=space, defer=cfg.defer_color)
        result = {"coarse": volume_render(self.fields["coarse"], split_params(params, "coarse"), origins, directions,
                                          near, far, sampler, bg, weights=weights or cfg.n_fine > 0, **kw),
                  "fine": None}
        if cfg.n_fine > 0:
            t, delta = sampler.points(n, near, far)
            sampler = importance_sample(t, delta, result["coarse"].weights, n, n_coarse, cfg.n_fine, seed,
                                        training)
            g = self.final_field()
            result["fine"] = volume_render(self.fields[g], split_params(params, g), origins, directions, near, far,
                                           sampler, bg, weights=weights, **kw)
            if not weights:
                result["coarse"] = replace(result["coarse"], weights=None)
        if weights:
            result["samples"] = sampler.points(n, near, far)
            result["spacing"] = space.spacing(*result["samples"], near, far, dr.select)
        return result


def sum_terms(terms):
    """The sum of the terms that are not None, or None."""
    terms = [t for t in terms if t is not None]
    return sum(terms[1:], terms[0]) if terms else None


def final(outputs: dict) -> RenderOutput:
    return outputs["fine"] if outputs.get("fine") is not None else outputs["coarse"]
