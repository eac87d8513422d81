"""How a recipe takes its sizes from the data (:meth:`~.recipes.Recipe.sized`): what it may derive, and the rules it
derives them by."""

from __future__ import annotations

from dataclasses import dataclass

from ..fields.grid import most_vertices as grid_most_vertices


SIZES = {"grid": ("resolution", "initial_resolution", "box", "cells", "density_refine"), "hashlinear": ("resolutions",),
         "render": ("n_coarse", "occupancy.march_bins", "occupancy.resolution")}
"""The settings :meth:`~.recipes.Recipe.sized` derives from the data, per field family and for the rendering."""
TV_SIZES = ("tv_weight", "tv_color_weight", "batch_rays", "mining")
"""What it derives too for a dense grid whose sizing has a :attr:`Sizing.tv_reference`
(:meth:`~.recipes.Recipe.sized_keys`)."""


def most_vertices(refine: int, dim: int = 3) -> int:
    """The most vertices a side a sized lattice of ``dim`` dimensions gets, its density ``refine`` times finer: the
    grid's own limit (:func:`mitnerf.fields.grid.most_vertices`)."""
    return grid_most_vertices(dim, refine)


@dataclass
class Sizing:
    """How a recipe takes its sizes from the data (:meth:`~.recipes.Recipe.sized`): its finest lattice as fine as the
    training images' pixels are at the scene, within a limit, reached coarse to fine; the sample spacing from the
    lattice's."""

    vertices_per_pixel: float = 1.0
    """Finest lattice spacing per pixel footprint at the scene's centre (the training cameras' median distance to
    the origin over the focal length): 1, one vertex per pixel."""
    max_resolution: int = 193
    """The finest lattice has at most as many vertices as a cube of this many a side (a box's fullest axis more):
    a dense grid's memory grows with its vertex count. A refined density lattice (``density_refine``) keeps the
    floats of that cube's grid, on fewer vertices (:attr:`GridConfig.refined_share`)."""
    doublings: int = 2
    """Coarse to fine: the lattice starts this many doublings coarser (the grid's ``initial_resolution``; the linearly
    decoded hash grid's levels, one per doubling)."""
    samples_per_vertex: float = 2.0
    """Occupancy bins along a ray (the finest sample spacing) per lattice spacing (per density spacing where the
    density is refined)."""
    samples: int = 64
    """Samples per ray (the occupancy sampler's slots)."""
    density_refine: int = 1
    """A dense grid's density takes a lattice this many times finer than its colour's (``GridConfig.density_refine``)
    where the training pixels ask for at least that density lattice: this many times the spacings of the colour
    lattice that keeps the cap's floats (:attr:`max_resolution`, :attr:`GridConfig.refined_share`). Edges and thin
    parts are what such views show best (``benchmarks/lego.py``). Views that ask for less (100 x 100 of an object)
    keep one lattice, at most the cap's; so does a lattice whose resolution is set on the recipe, unless its
    ``density_refine`` is set too."""
    depth_cells: float = 0.125
    """Forward-facing scenes (a dense grid in NDC): cells along the depth axis ``z'`` per cell along ``x'``. NDC's
    ``x'`` and ``y'`` span the views' width and height, so the lattice's cells there follow the images' pixels, and
    ``z'``, even in disparity, needs far fewer."""
    tv_reference: float | None = None
    """A dense grid's lattice vertices per training pixel at which the recipe's total-variation weights hold; data
    with fewer (more pixels to pin each vertex) scales both weights down in proportion, as a prior's weight falls
    with the observations against it, and a step takes twice the recipe's rays, or mines them (:attr:`mining`;
    ``benchmarks/lego.py``). None: the recipe's weights and batch whatever the data."""
    mining: float = 0.0
    """Where the data has more pixels than the lattice vertices (:attr:`tv_reference`), the share of each batch
    drawn from the pixels' errors (``TrainConfig.mining``) in place of twice the recipe's rays: as many steps as the
    recipe's batch takes, their rays where the field is still wrong. 0: twice the rays, drawn uniformly."""
    fixed: tuple = ()
    """Sizes set on the recipe (:meth:`~.recipes.Recipe.override`), which the data leaves alone."""
