"""Recipes: THE place where hyperparameters are written; a recipe is a named, tuned training run
(field settings, sampling, optimisation) for one field family in one dimension."""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..fields import FIELDS
from ..render.occupancy import OccupancyConfig
from ..render.pipeline import RenderConfig
from ..settings import field_named
from .config import ModelConfig, TrainConfig
from .sizing import SIZES, TV_SIZES, Sizing, most_vertices


@dataclass
class Recipe:
    """A named model + training configuration."""

    name: str
    """Unique name, ``<family>-<dim>d`` for the tuned recipe of a family."""
    dim: int
    """Dimension of the datasets it is tuned for (2 or 3)."""
    model: ModelConfig
    """Field family and settings, samples, fine pass, occupancy grid."""
    train: TrainConfig
    """Budget, batch, learning-rate schedule, losses."""
    about: str = ""
    """How it is made, and why."""
    purpose: str = ""
    """What it is for, in a few words (``mitnerf recipes`` leads with it)."""
    sizing: Sizing | None = None
    """Where set, the field's lattice and the samples per ray come from the data (:meth:`sized`); None: as written."""

    def copy(self) -> "Recipe":
        return copy.deepcopy(self)

    def to_dict(self) -> dict:
        return {"name": self.name, "dim": self.dim, "model": self.model.to_dict(),
                "train": dataclasses.asdict(self.train), "about": self.about, "purpose": self.purpose,
                "sizing": None if self.sizing is None else dataclasses.asdict(self.sizing)}

    @classmethod
    def from_dict(cls, d: dict) -> "Recipe":
        train = {k: v for k, v in d["train"].items() if k in TrainConfig.__dataclass_fields__}
        sizing = d.get("sizing")
        return cls(d["name"], int(d["dim"]), ModelConfig.from_dict(d["model"]), TrainConfig(**train),
                   d.get("about", ""), d.get("purpose", ""),
                   None if sizing is None else Sizing(**{**sizing, "fixed": tuple(sizing["fixed"])}))

    def sized(self, dataset) -> "Recipe":
        """A copy with the sizes :attr:`sizing` takes from ``dataset`` (``self`` where it has none): a dense grid's
        lattice spans the box around the training views' visual hull where the data has one (:attr:`Dataset.hull_box`,
        an object scene), else the cube of the bound; its fullest axis has ``R`` vertices, one per
        :attr:`Sizing.vertices_per_pixel` pixel footprints, about as many in all at most as a cube of
        :attr:`Sizing.max_resolution`, rounded to ``c 2^d + 1`` (``d`` doublings, coarse to fine from ``c + 1``);
        occupancy bins of :attr:`Sizing.samples_per_vertex` per lattice spacing over [near, far],
        an occupancy cell per two lattice spacings (up to 128 per axis); a dense grid's total-variation weights
        scaled by the lattice's vertices per training pixel, and its batch doubled or mined
        (:attr:`Sizing.tv_reference`, :attr:`Sizing.mining`). In a forward-facing scene (NDC) a dense grid's cells
        are in the proportions of the training images' width, height and :attr:`Sizing.depth_cells` times the width;
        the fullest axis takes :attr:`Sizing.vertices_per_pixel` vertices a pixel of the images' longer side, and the
        occupancy grid keeps the recipe's sizes. A grid whose density is refined (``density_refine`` k) keeps the
        cap's floats on fewer vertices (:attr:`GridConfig.refined_share`), with :attr:`Sizing.samples_per_vertex`
        bins a density spacing; the recipe's :attr:`Sizing.density_refine` is that k where the pixels ask for it. A
        size set on the recipe stays."""
        if self.sizing is None:
            return self
        out, s = self.copy(), self.sizing
        out.sizing, args, r = None, out.model.field_args, out.model.render
        d = s.doublings
        grid, cams = out.model.field == "grid", dataset["train"].cameras
        ndc = r.scene == "forward"
        if not grid or "box" in s.fixed:
            box = args.get("box")
        else:
            box = dataset.hull_box if r.scene in ("object", "auto") else None
        if grid and ndc and "cells" not in s.fixed:            # NDC: x', y' across the views, z' along depth
            args["cells"] = (float(cams.width), float(cams.height), s.depth_cells * cams.width)
        cells = args.get("cells")
        extent = [h - l for l, h in zip(box[:dataset.dim], box[dataset.dim:])] if box else [2 * dataset.bound]
        share = [e / max(cells or extent) for e in (cells or extent)]
        full = extent[int(np.argmax(share))] if len(extent) == len(share) else extent[0]   # the fullest axis' length
        k = int(args.get("density_refine", 1)) if grid else 1      # density spacings per lattice spacing
        if "resolution" in s.fixed or "resolutions" in s.fixed:
            top = args["resolution"] if "resolution" in s.fixed else max(args["resolutions"])
        else:
            footprint = float(np.median(np.linalg.norm(cams.origins, axis=1)) / np.median(cams.fx))  # any lens
            across = max(cams.width, cams.height) if ndc else full / footprint  # pixels along the fullest axis

            config = out.model.field_config(dataset.dim)

            def cap(refine: int) -> float:           # the fullest axis in the cap's floats, density refined so
                kept = dataclasses.replace(config, density_refine=refine).refined_share if refine > 1 else 1.0
                cube = s.max_resolution * kept ** (1 / dataset.dim)
                axis = (cube - 1) / float(np.prod(share)) ** (1.0 / len(share)) + 1
                return min(axis, most_vertices(refine, dataset.dim))

            wanted = across * s.vertices_per_pixel + 1
            j = s.density_refine                                 # refined where the pixels ask for its density
            if grid and "density_refine" not in s.fixed and j > 1 and wanted >= j * (cap(j) - 1) + 1:
                k = j
            top = min(wanted, cap(k))
        c = max(2, round((top - 1) / 2 ** d))
        if "resolution" not in s.fixed and "resolutions" not in s.fixed:
            c = min(c, (most_vertices(k, dataset.dim) - 1) // 2 ** d)     # rounded up no further than the limit
        R = c * 2 ** d + 1
        sizes = {"resolution": R, "initial_resolution": c + 1, **({"box": box} if box else {}),
                 "resolutions": tuple(c * 2 ** j + 1 for j in range(d + 1)), "n_coarse": s.samples,
                 "occupancy.resolution": min(128, round((R - 1) * dataset.bound / full)),
                 "occupancy.march_bins": int(np.ceil((dataset.far - dataset.near) * s.samples_per_vertex * k * (R - 1)
                                                     / full)), **({"density_refine": k} if k > 1 else {})}
        if "batch_rays" in self.sized_keys():
            shape = FIELDS["grid"][0](dim=dataset.dim, box=box, cells=cells, bound=dataset.bound).lattice(R)
            per_pixel = float(np.prod(shape)) / (len(cams) * cams.width * cams.height)
            sizes.update({k: args[k] * min(1.0, per_pixel / s.tv_reference) for k in ("tv_weight", "tv_color_weight")
                          if k in args})
            mining = out.train.mining if "mining" in s.fixed else s.mining
            if per_pixel < s.tv_reference and mining:       # more pixels than vertices: mined rays,
                sizes["mining"] = mining
            elif per_pixel < s.tv_reference:                # or twice the rays
                sizes["batch_rays"] = 2 * out.train.batch_rays
        for key in self.sized_keys():
            if key not in s.fixed and key in sizes and not (ndc and key.startswith("occupancy.")):
                if key.startswith("occupancy."):
                    setattr(r.occupancy, key.split(".", 1)[1], sizes[key])
                elif key == "n_coarse":
                    r.n_coarse = sizes[key]
                elif key in ("batch_rays", "mining"):
                    setattr(out.train, key, sizes[key])
                else:
                    args[key] = sizes[key]
        return out

    def override(self, *, nulls: bool = False, **settings) -> "Recipe":
        """A copy with some settings replaced: a :class:`TrainConfig` or :class:`RenderConfig` field,
        ``occupancy.<field>`` or a setting of the field family (``width``); ``None`` values are ignored unless
        ``nulls`` (a ``--set key=null``)."""
        out = self.copy()
        for key, value in ((k, v) for k, v in settings.items() if v is not None or nulls):
            if key in TrainConfig.__dataclass_fields__:
                setattr(out.train, key, value)
            elif key in RenderConfig.__dataclass_fields__ and key != "occupancy":
                setattr(out.model.render, key, tuple(value) if isinstance(value, list) else value)
            elif key.startswith("occupancy."):
                sub = key.split(".", 1)[1]
                if sub not in OccupancyConfig.__dataclass_fields__:
                    raise ConfigError(f"the occupancy grid has no setting {sub!r}")
                setattr(out.model.render.occupancy, sub, value)
            else:
                out.model.field_args[key] = value
            if out.sizing is not None and key in out.sized_keys():
                out.sizing = dataclasses.replace(out.sizing, fixed=(*out.sizing.fixed, key))
        return out._marked(self)

    def sized_keys(self) -> tuple:
        """The settings :meth:`sized` derives from the data for this recipe (one set on it stays: ``Sizing.fixed``)."""
        tv = self.model.field == "grid" and self.sizing is not None and self.sizing.tv_reference is not None
        return SIZES.get(self.model.field, ()) + SIZES["render"] + (TV_SIZES if tv else ())

    def at_steps(self, steps: int, **settings) -> "Recipe":
        """A copy that trains exactly ``steps`` steps with no time budget (runs compared at equal steps, whatever
        the machine's speed); other ``settings`` as :meth:`override`."""
        out = self.override(iters=steps, **settings)
        out.train.time_budget = None
        return out._marked(self)

    def _marked(self, base: "Recipe") -> "Recipe":
        """``self``, named ``<base's name>+`` when its settings differ from ``base``'s (a modified recipe says so)."""
        if self.essence() != base.essence() and not base.name.endswith("+"):
            self.name = base.name + "+"
        return self

    def declared(self, key: str):
        """``(config class, its dataclass field)`` declaring ``key`` in this recipe: a training or rendering
        setting, ``occupancy.<name>``, or a setting of its field family; None when it has no such setting."""
        if key.startswith("occupancy."):
            f = field_named(OccupancyConfig, key.split(".", 1)[1])
            return (OccupancyConfig, f) if f else None
        for cls in (TrainConfig, RenderConfig, FIELDS[self.model.field][0]):
            f = field_named(cls, key)
            if f is not None and key not in ("occupancy", "dim", "bound"):
                return cls, f
        return None

    def has(self, key: str) -> bool:
        """Whether the recipe has the setting ``key`` (:meth:`declared`)."""
        return self.declared(key) is not None

    def get(self, key: str):
        """A setting's value (a field setting's default when the recipe does not set it)."""
        cls = self.declared(key)[0] if self.has(key) else None
        if cls is TrainConfig:
            return getattr(self.train, key)
        if cls is RenderConfig:
            return getattr(self.model.render, key)
        if cls is OccupancyConfig:
            return getattr(self.model.render.occupancy, key.split(".", 1)[1])
        return getattr(self.model.field_config(self.dim), key)

    def essence(self) -> dict:
        """The settings that change what is trained (not progress bars, thread counts or test views, nor the scene,
        which the data decides like the box); field settings with their defaults filled in, so a setting written at its
        default value changes nothing."""
        d = self.to_dict()
        d["model"]["render"] = {k: v for k, v in d["model"]["render"].items() if k not in ("scene", "frame")}
        full = dataclasses.asdict(self.model.field_config(self.dim))
        d["model"]["field_args"] = {k: v for k, v in full.items() if k != "dim"}
        d["train"] = {k: v for k, v in d["train"].items() if k not in ("progress", "threads", "test_views")}
        return {k: v for k, v in d.items() if k not in ("name", "about", "purpose")}

    def validate(self) -> "Recipe":
        self.model.validate(self.dim)
        self.train.validate()
        return self

    def summary(self) -> str:
        """One line: the family and its settings (its network's ``mode`` always), samples, budget, rate, losses."""
        args = {**self.model.field_args, **({"mode": self.get("mode")} if self.has("mode") else {})}
        args = ", ".join(f"{k}={v}" for k, v in args.items())
        r, t = self.model.render, self.train
        budget = f"{t.time_budget:g} s" if t.time_budget else f"{t.iters} steps"
        mined = (f" mined {t.mining:g} (alpha {t.mining_alpha:g}, tiles of {t.mining_tile})" if t.mining else "")
        occ = (f", occupancy grid {r.occupancy.resolution}^{self.dim} of {r.occupancy.march_bins} bins a ray"
               if r.occupancy.enabled else "")
        fine = f" + {r.n_fine} fine" if r.n_fine else ""
        reach = {"solid_weight": f" (reach {t.solid_thickness:g})"}
        losses = "".join(f", {k.rsplit('_', 1)[0].replace('_', ' ')} {getattr(t, k):g}{reach.get(k, '')}"
                         for k in ("depth_weight", "free_space_weight", "solid_weight", "distortion_weight",
                                   "opacity_weight")
                         if getattr(t, k))
        s = self.sizing
        sized = (f" (sizes from the data: {s.vertices_per_pixel:g} vertex per pixel, up to {s.max_resolution})"
                 if s is not None else "")
        return (f"{self.name}: {self.model.field} ({args}){sized}; {r.n_coarse}{fine} samples{occ}; "
                f"{budget}, batch {t.batch_rays}{mined}, lr {t.lr:g} -> {t.lr_final:g}{losses}")


PURPOSE = {
    "grid-2d": "the default for 2D data: the most accurate in seconds",
    "vanilla-2d": "NeRF's MLP: the reference architecture, for comparisons rather than speed",
    "hashgrid-2d": "instant-ngp's hash grid with tiny networks",
    "hashlinear-2d": "a hash grid decoded linearly: grid-2d's accuracy with a sixth of its parameters",
    "grid-3d": "the default for 3D data",
    "hashlinear-3d": "grid-3d's model in a hash grid decoded linearly, with far fewer parameters",
    "vanilla-3d": "NeRF's MLP with its fine pass: the reference architecture",
    "hashgrid-3d": "instant-ngp's hash grid with tiny networks",
    "pixelnerf-2d": "2D pixelNeRF, trained across scenes by `mitnerf experiment pixelnerf`",
    "grid-forward": "the default for forward-facing captures (LLFF's fern): a grid in NDC",
    "grid-unbounded": "the default for captures of an object in a room (instant-ngp's fox): a grid in contracted space",
}


def _r(name, dim, field, args, render, train, about, sizing=None) -> Recipe:
    return Recipe(name, dim, ModelConfig(field, args, RenderConfig(**render)), TrainConfig(**train), about,
                  PURPOSE[name], sizing)


_BUDGET = dict(iters=1_000_000)          # time-budgeted recipes: the clock decides, not the step count
RECIPES: dict[str, Recipe] = {r.name: r for r in [
    _r("grid-2d", 2, "grid", dict(resolution=257, initial_resolution=129, upsample_at=(150,), tv_weight=1e-4,
                                  view_dependent=True, sh_degree=2, tv_color_weight=1e-2),
       dict(n_coarse=128), dict(time_budget=10.0, lr=0.3, lr_final=0.005, batch_rays=1024, distortion_weight=1e-3,
                                opacity_weight=1e-3, free_space_weight=1.0, solid_weight=0.1, solid_thickness=0.15,
                                **_BUDGET),
       "harmonics to degree 2 (a highlight is narrower than one cosine); a high learning rate (a budget of seconds "
       "buys few steps, in which density has to go from transparent to opaque); free space from alpha too"),
    _r("vanilla-2d", 2, "vanilla", dict(width=64, depth=4, pos_L=8, dir_L=4, mode="native"), dict(n_coarse=64),
       dict(time_budget=10.0, lr=5e-3, lr_final=2e-4, batch_rays=1024, **_BUDGET),
       "for comparisons at equal time (it needs minutes to match a grid: --time-budget 300)"),
    _r("hashgrid-2d", 2, "hashgrid", dict(n_levels=8, log2_hashmap_size=14, hidden=16, geo_features=7, mode="tensor"),
       dict(n_coarse=48),
       dict(time_budget=10.0, lr=0.05, lr_final=0.005, batch_rays=1024, **_BUDGET),
       "a high learning rate (a lower one fits the training views and not the test views); no occupancy grid (in 2D "
       "it skips less than it costs, and pruning in the first steps can leave a fit in a poor optimum)"),
    _r("hashlinear-2d", 2, "hashlinear", dict(resolutions=(65, 129, 257), dense_levels=2, log2_hashmap_size=13,
                                              view_levels=1, sh_degree=2, initial_levels=2, add_level_at=(150,)),
       dict(n_coarse=128), dict(time_budget=10.0, lr=0.3, lr_final=0.005, batch_rays=1024, distortion_weight=1e-3,
                                opacity_weight=1e-3, free_space_weight=1.0, solid_weight=0.1, solid_thickness=0.15,
                                **_BUDGET),
       "the levels summed into one density and colour (view harmonics on the coarsest level); grid-2d's losses and "
       "rate"),
    _r("grid-3d", 3, "grid", dict(resolution=129, initial_resolution=33, upsample_at=(200, 600), tv_weight=1e-5,
                                  view_dependent=True, tv_color_weight=3e-4),
       dict(n_coarse=64, occupancy=dict(enabled=True, resolution=64, march_bins=256, early_stop=1e-3),
            render_oversample=4),
       dict(time_budget=60.0, lr=0.2, lr_final=0.005, batch_rays=8192, distortion_weight=1e-3, opacity_weight=1e-3,
            free_space_weight=1.0, solid_weight=0.1, solid_thickness=0.3, **_BUDGET),
       "the lattice over the box around the views' visual hull where the data has one, as many vertices as a 161^3 "
       "cube at most (the grid's training state grows with them); where the views ask for a density lattice twice "
       "as fine as the cap's floats hold refined (the lego's 400 x 400 views), the density on a lattice twice as fine "
       "as the colour's; a high learning rate (a budget of seconds buys few steps); a density TV ten times and a "
       "colour TV 30 times weaker than 2D's (views of 100 x 100 and more carry detail, texture and highlights that "
       "2D's weights blur away), both scaled down where the lattice has fewer vertices than the training views have "
       "pixels (the lego's 100 views of 400 x 400: 0.17 colour vertices a pixel), where a step also draws most of "
       "its rays where the field's last errors were (mining 0.8) rather than uniformly; a ray's training samples "
       "end where its transmittance falls to 1e-3 (early_stop), so a thick object's front gets them; renders with "
       "four times the samples of training on the same occupancy bins (benchmarks/lego.py, part quadrature)",
       Sizing(vertices_per_pixel=1.5, max_resolution=161, doublings=2, samples_per_vertex=1.0, tv_reference=1.0,
              density_refine=2, mining=0.8)),
    _r("hashlinear-3d", 3, "hashlinear", dict(resolutions=(33, 65, 129), dense_levels=2, log2_hashmap_size=19,
                                              view_levels=1, initial_levels=2, add_level_at=(300, 700),
                                              tv_color_weight=3e-4),
       dict(n_coarse=64, occupancy=dict(enabled=True, resolution=64, march_bins=256)),
       dict(time_budget=60.0, lr=0.2, lr_final=0.005, batch_rays=8192, distortion_weight=1e-3, opacity_weight=1e-3,
            free_space_weight=1.0, solid_weight=0.1, solid_thickness=0.3, **_BUDGET),
       "one level per doubling up to the data's lattice (at most 385^3), the finer ones hashed; grid-3d's losses, "
       "occupancy grid, batch and rate",
       Sizing(vertices_per_pixel=1.5, max_resolution=385, doublings=3, samples_per_vertex=1.0)),
    _r("vanilla-3d", 3, "vanilla", dict(width=64, depth=4, pos_L=10, dir_L=4, mode="native"),
       dict(n_coarse=64, n_fine=32),
       dict(time_budget=60.0, lr=5e-3, lr_final=2e-4, batch_rays=2048, **_BUDGET),
       "NeRF's hierarchical sampling, for comparisons at equal time"),
    _r("hashgrid-3d", 3, "hashgrid", dict(n_levels=12, log2_hashmap_size=16, base_resolution=16, max_resolution=512,
                                          mode="tensor"),
       dict(n_coarse=48, occupancy=dict(enabled=True, resolution=64, march_bins=256)),
       dict(time_budget=60.0, lr=0.01, lr_final=0.001, batch_rays=2048, **_BUDGET),
       "instant-ngp's levels and networks with an occupancy grid"),
    _r("grid-forward", 3, "grid", dict(resolution=129, initial_resolution=33, upsample_at=(300, 1000), tv_weight=1e-4,
                                       view_dependent=False, tv_color_weight=3e-4),
       dict(n_coarse=64, scene="forward", occupancy=dict(enabled=True)),
       dict(time_budget=600.0, lr=0.2, lr_final=0.005, batch_rays=4096, distortion_weight=1e-3, opacity_weight=1e-3,
            **_BUDGET),
       "grid-3d's grid in normalised device coordinates (NeRF's LLFF setting), samples even in disparity and placed "
       "in occupied space by an occupancy grid; a lattice of a vertex a pixel across and an eighth as many along "
       "depth, within 241^3 vertices; a colour without view dependence, four floats a vertex where harmonics of "
       "degree 1 take 13, so the same time buys a finer lattice and more steps (benchmarks/captures.py: fern/fit)",
       Sizing(vertices_per_pixel=1.0, max_resolution=241, doublings=2, depth_cells=0.125)),
    _r("grid-unbounded", 3, "grid", dict(resolution=193, initial_resolution=49, upsample_at=(300, 1000),
                                         tv_weight=1e-3, view_dependent=True, tv_color_weight=3e-3),
       dict(n_coarse=64, scene="unbounded", occupancy=dict(enabled=True, resolution=64, march_bins=512)),
       dict(time_budget=600.0, lr=0.2, lr_final=0.005, batch_rays=4096, distortion_weight=1e-3, opacity_weight=1e-3,
            **_BUDGET),
       "grid-3d's grid in mip-NeRF 360's contracted space, 193^3 vertices, the colour view-dependent (unlike "
       "grid-forward's: the fox fits far worse without it), samples linear then even in disparity; total variation "
       "ten times grid-forward's (the room behind the object is seen from few views; benchmarks/captures.py: fox/fit)"),
    _r("pixelnerf-2d", 2, "pixelnerf", {}, dict(n_coarse=32),
       dict(iters=8000, time_budget=150.0, lr=2e-3, lr_final=2e-4, batch_rays=32, val_every=0),
       "2D pixelNeRF trained across scenes (`mitnerf experiment pixelnerf`): 32 rays x 32 samples per step"),
]}
DEFAULT = {2: "grid-2d", 3: "grid-3d", "forward": "grid-forward", "unbounded": "grid-unbounded"}
"""The default recipe for data of each dimension, and for forward-facing and unbounded captures (``--scene``)."""

# The sizes the searches try: each a family and settings on top of the family's recipe.
LADDER = {
    2: [("grid", dict(resolution=r, initial_resolution=min(r, 129), upsample_at=(150, 400)))
        for r in (33, 65, 129, 513)]
    + [("vanilla", dict(width=64, depth=4, pos_L=8, dir_L=2))]
    + [("hashgrid", dict(n_levels=8, log2_hashmap_size=T, hidden=16, geo_features=7)) for T in (12, 14)]
    + [("hashlinear", dict(resolutions=(65, 129, 257), dense_levels=2, log2_hashmap_size=13))],
    3: [("vanilla", dict(width=64, depth=4, pos_L=8, dir_L=2))]
    + [("hashgrid", dict(n_levels=12, log2_hashmap_size=T)) for T in (14, 16)]
    + [("hashlinear", dict(resolutions=(33, 65, 129), dense_levels=2, log2_hashmap_size=17))],
}
"""``fit --auto``'s candidates besides the default recipe (which it probes first, sized from the data) and, in 3D,
the default's lattice with :data:`GRID_DIVISIONS` times fewer spacings: (family, settings on top of the family's
recipe), probed smallest first."""

GRID_DIVISIONS = (2, 4)
"""In 3D (an object, a forward-facing or an unbounded scene), ``fit --auto`` also probes the dense grid the default
recipe sizes from the data with its spacings along the fullest axis divided by each of these: the data's own
lattice and the coarser ones, whatever the views' size (the lego's 400 x 400 views: 197, 97 and 49 vertices, each
density twice as fine)."""

SWEEP_SIZES = {"vanilla": {"w32": dict(width=32), "recipe": {}},
         "grid": {"small": {2: dict(resolution=129, initial_resolution=33, upsample_at=(100,)),
                            3: dict(resolution=65, initial_resolution=33, upsample_at=(200,))}, "recipe": {}},
         "hashgrid": {"T12": dict(log2_hashmap_size=12), "recipe": {}}}
"""``mitnerf sweep``'s sizes, per family: size label -> settings on top of its recipe (or ``{dim: settings}``)."""


def get_recipe(name: str) -> Recipe:
    """A fresh copy of the recipe ``name``."""
    if name not in RECIPES:
        raise ConfigError(f"no recipe {name!r}; choose one of {', '.join(RECIPES)} (`mitnerf recipes` lists them)")
    return RECIPES[name].copy()


def recipe_for(field: str | None, dim: int, scene: str = "object") -> Recipe:
    """The tuned recipe of ``field`` (the default one when None) for datasets of ``dim`` showing ``scene``: a
    forward-facing or unbounded scene's own recipe where the family has one, else its 3D recipe in that scene."""
    if scene in ("forward", "unbounded"):
        name = DEFAULT[scene] if field is None else f"{field}-{scene}"
        if name in RECIPES:
            return get_recipe(name)
        out = recipe_for(field, dim)
        out.model.render.scene = scene
        return out
    if field is None:
        return get_recipe(DEFAULT[dim])
    name = f"{field}-{dim}d"
    if name not in RECIPES:
        fams = sorted({r.model.field for r in RECIPES.values() if r.dim == dim and r.model.field != "pixelnerf"})
        raise ConfigError(f"no {dim}D recipe for field {field!r}; choose --field {' or '.join(fams)}")
    return get_recipe(name)
