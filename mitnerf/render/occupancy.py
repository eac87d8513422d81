"""Empty-space skipping: an occupancy grid (as in instant-ngp / nerfacc) and a sampler of occupied space.

The grid covers ``[-bound, bound]^D`` with ``resolution^D`` cells. An update measures each cell's density
at a jittered point in it and keeps ``value = max(decay * value, measured)``; a cell is occupied while
``value > min(threshold, mean(value))`` (every cell, before the first update).

The sampler looks the centres of ``M = march_bins`` equal bins of ``[near, far]`` up in the grid. Of a
ray's ``K`` occupied bins, every ``stride = ceil(K / N)``-th starts a group: one jittered sample in that
bin stands for the group's ``stride * dt`` (the last group: the bins left). Unused slots get ``delta = 0``;
the count stays ``N``, so the step can be frozen, and the integral stops at each ray's last used slot. With an
early stop (:attr:`OccupancyConfig.early_stop`, in training) a ray's occupied bins end where the optical depth of
those in front, by the field's density at their centres, reaches ``-ln(early_stop)``: ``K`` counts only those.
Without it, one pass over the bins counts them and places the samples of every ray with ``K <= N`` (stride 1);
only the rays with more occupied bins than slots pass again (the renders' time: ``benchmarks/lego.py``). Only
the bins within the box around the occupied cells (:attr:`OccupancyGrid.box`, one bin of margin) are looked up:
the others are empty, so the samples are those of every bin. Where the bins are even in distance, a pass crosses
an empty cell in one step, to the last bin whose centre lies at most where the ray leaves it
(``OccupiedSampler._next_bin``; the second pass, which empties a slot per bin, steps by one). In a
forward-facing or unbounded scene (:mod:`.space`) the grid covers the warped space the fields live in, the bins are
even in the samples' spacing (:func:`.space.to_s`) and every bin is looked up (rays curve there: no box bounds
them).
Twin: :mod:`mitnerf.reference.render.occupancy`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32

from ..settings import setting
from ..rng import uniform
from .integral import in_lanes
from .samplers import Explicit, grouped, per_sample
from .space import DRJIT, Space, to_s, to_t


@dataclass
class OccupancyConfig:
    """Empty-space skipping."""

    enabled: bool = setting(False, flag="--occupancy")
    """Skip empty space with an occupancy grid of the density."""
    resolution: int = setting(128, lo=2, hi=1024)
    """Cells per axis of the grid."""
    update_every: int = setting(16, lo=1, hi=10 ** 9)
    """Training steps between grid updates."""
    warmup: int = setting(64, lo=0, hi=10 ** 9)
    """Steps before the first update (the field has learned nothing yet)."""
    decay: float = setting(0.95, lo=0.0, hi=1.0)
    """Decay of the running density per update."""
    threshold: float = setting(0.01, lo=0.0, hi=1e9)
    """Density below which a cell is empty (or the mean, if that is smaller)."""
    march_bins: int = setting(512, lo=1, hi=1 << 16)
    """Bins per ray in which occupancy is looked up (the finest sample spacing)."""
    early_stop: float = setting(0.0, lo=0.0, hi=0.5)
    """In training, a ray's samples end where its transmittance through the occupied bins, by the field's detached
    density at their centres, falls below this (nerfacc's ``early_stop_eps``): its slots go to the bins in front,
    finer there, where a ray through a thick object would spread them over bins it cannot see. 0: over all the
    occupied bins. A render (no gradients) ends each march by its integral's transmittance instead
    (:mod:`.integral`), on all its slots; a field that does not run inside the march (``traceable``: not the
    tensor-mode networks) spreads them too. ``benchmarks/lego.py``."""


def cell_coords(x: list, bound: float, res: int) -> tuple[list, object]:
    """The cell of points ``x`` (D arrays) along each axis (``UInt32``, clamped to the grid) and whether they lie
    inside the grid."""
    coords, inside = [], None
    for xi in x:
        u = (xi * (1.0 / bound) + 1.0) * (0.5 * res)
        ok = (u >= 0.0) & (u < res)
        inside = ok if inside is None else inside & ok
        coords.append(UInt32(dr.clip(u, 0.0, res - 1.0)))
    return coords, inside


def flat_index(coords: list, res: int) -> UInt32:
    """The flat index (x fastest) of the cells ``coords`` (:func:`cell_coords`)."""
    return sum((c * res ** a for a, c in enumerate(coords)), UInt32(0))


def cell_index(x: list, bound: float, res: int):
    """Flat cell index of points ``x`` (D arrays) and whether they lie inside the grid."""
    coords, inside = cell_coords(x, bound, res)
    return flat_index(coords, res), inside


class OccupancyGrid:
    """The running densities and the occupied mask; see the module docstring."""

    def __init__(self, cfg: OccupancyConfig, dim: int, bound: float):
        self.cfg, self.dim, self.bound = cfg, dim, bound
        n = cfg.resolution ** dim
        self.value = dr.zeros(Float, n)
        self.occupied = dr.full(Float, 1.0, n)      # 1 occupied / 0 empty (a Float: a PyTree leaf)
        self.box = self._box()
        """``[2 D]``: the lower and the upper corner of the box around the occupied cells (world units)."""

    def _box(self) -> Float:
        res, b = self.cfg.resolution, self.bound
        idx = dr.arange(UInt32, res ** self.dim)
        occ = self.occupied > 0.5
        lo = [dr.min(dr.select(occ, Float((idx // res ** a) % res), res)) for a in range(self.dim)]
        hi = [dr.max(dr.select(occ, Float((idx // res ** a) % res) + 1.0, 0.0)) for a in range(self.dim)]
        box = Float(np.concatenate([np.asarray(v) for v in lo + hi])) * (2.0 * b / res) - b
        dr.eval(box)
        return box

    @property
    def lookup(self) -> tuple:
        """What the sampler reads: ``(occupied, box)``."""
        return self.occupied, self.box

    def cell_centres(self, jitter: Float | None = None) -> list:
        res = self.cfg.resolution
        idx = dr.arange(UInt32, res ** self.dim)
        pts = []
        for a in range(self.dim):
            off = 0.5 if jitter is None else uniform(UInt32(jitter), idx, UInt32(a))
            pts.append(((Float((idx // res ** a) % res) + off) * (2.0 / res) - 1.0) * self.bound)
        return pts

    def update(self, density_fn, step: int, seed: int) -> None:
        """Measure ``density_fn(points) -> Float`` in every cell and refresh the mask."""
        if step < self.cfg.warmup:
            return
        with dr.suspend_grad():
            sigma = dr.detach(density_fn(self.cell_centres(jitter=seed)))
            self.value = dr.maximum(self.value * self.cfg.decay, sigma)
            level = dr.minimum(dr.mean(self.value), self.cfg.threshold)
            self.occupied = dr.select(self.value > level, 1.0, 0.0)
            dr.eval(self.value, self.occupied)
            self.box = self._box()

    def state(self) -> dict:
        return {"value": np.asarray(self.value), "occupied": np.asarray(self.occupied)}

    def load(self, state: dict) -> None:
        self.value, self.occupied = Float(state["value"]), Float(state["occupied"])
        self.box = self._box()


@dataclass
class OccupiedSampler:
    """``n`` samples per ray from the occupied bins (see the module docstring)."""

    occupied: Float
    box: Float
    n: int
    bins: int
    bound: float
    resolution: int
    seed: UInt32
    jitter: bool = True
    space: Space = Space()
    density: Callable[[list], Float] | None = None
    """``density(x) -> Float``, the field's detached density at points ``x`` (the grid's space; in a warped space
    stretched into density per unit of distance, as the renderer does), with :attr:`early_stop`: where the march
    may end; None: at the last occupied bin."""
    early_stop: float = 0.0
    """Transmittance at which the occupied bins end (:attr:`OccupancyConfig.early_stop`)."""
    fill: bool = True
    """Write ``t = far, delta = 0`` to the slots past each ray's count; False leaves them unwritten, which saves two
    passes over the ``n_rays * n`` slots where nothing reads them: a march reads only a ray's counted slots, and
    :meth:`~.samplers.Explicit.points` reads the others as those values (renders)."""
    grouped: bool = False
    """Look the rays up grouped by their count of bins (:func:`~.samplers.grouped`): for a training batch, whose rays
    come in no order; a view's rays come in pixel order, which groups them already and keeps neighbours together."""

    def _at(self, k: Float, near: Float, far: Float) -> Float:
        """Distance of the point ``k`` (fractional) bins along ``[near, far]``."""
        knee = self.space.knee
        if knee is None:
            return near + k * ((far - near) * (1.0 / self.bins))
        lo, hi = (to_s(v, knee, dr.select) for v in (near, far))
        return to_t(lo + k * ((hi - lo) * (1.0 / self.bins)), knee, dr.select)

    def _span(self, k: UInt32, n, near: Float, far: Float, dt: Float) -> Float:
        """Length of the ``n`` bins from bin ``k`` along ``[near, far]`` (``dt``: a bin's, where they are even)."""
        if self.space.knee is None:
            return Float(n) * dt
        return self._at(Float(k + n), near, far) - self._at(Float(k), near, far)

    def _bin_occupied(self, o: list, d: list, k, near, far):
        """Whether bin ``k``'s centre on the lanes' rays ``o + t d`` is in an occupied cell; that centre in the
        grid's space; the density stretch there (1 where nothing is warped); whether it is in the grid; its cell
        along each axis (:func:`cell_coords`)."""
        t = self._at(Float(k) + 0.5, near, far)
        x = [oi + t * di for oi, di in zip(o, d)]
        stretch = 1.0
        if self.space.warped:
            x, stretch = self.space.warp(x, d, DRJIT)
        coords, inside = cell_coords(x, self.bound, self.resolution)
        occ = inside & (dr.gather(Float, self.occupied, flat_index(coords, self.resolution), inside) > 0.5)
        return occ, x, stretch, inside, coords

    def _faces(self, d: list, dt: Float) -> list | None:
        """Per ray and axis, ``(s, r, moving)``: a centre ``x`` in a cell of coordinate ``c`` along that axis lies
        ``(c h + s - x) r`` bins before the ray leaves the cell that way (``h`` a cell's side); ``moving`` is false
        where the ray runs along the axis's faces (it never leaves that way). None where the bins are not even in
        distance (a knee, a warped space)."""
        if self.space.knee is not None or self.space.warped:
            return None
        h, out = 2.0 * self.bound / self.resolution, []
        for di in d:
            moving = dr.abs(di) > 1e-12
            out.append((dr.select(di > 0.0, h, 0.0) - self.bound, dr.select(moving, 1.0 / (di * dt), 0.0), moving))
        return out

    def _next_bin(self, faces: list | None, k: UInt32, x: list, coords: list, empty, end: UInt32) -> UInt32:
        """The next bin to look up after bin ``k``, whose centre ``x`` is in cell ``coords`` (:func:`cell_coords`),
        an ``empty`` one or not: past an empty cell, the last bin whose centre lies at most where the ray leaves it
        (the bins before lie in it, empty too: a cell is convex), so a march crosses an empty cell in one step, not
        in one per bin; else ``k + 1``; never past ``end``. The exit is measured from ``x`` (a short distance over
        the direction, so a ray nearly parallel to a face does not subtract two large numbers); the bins looked up,
        and so the samples, are those of a step by one. ``faces``: :meth:`_faces`; None: a step by one."""
        if faces is None:
            return k + 1
        h, leave = 2.0 * self.bound / self.resolution, Float(np.inf)
        for xi, c, (s, r, moving) in zip(x, coords, faces):
            leave = dr.minimum(leave, dr.select(moving, (dr.fma(Float(c), h, s) - xi) * r, np.inf))
        last = UInt32(dr.clip(leave + (Float(k) + 0.5), 0.0, float(self.bins)))   # floor: centre at most the exit
        return dr.select(empty, dr.minimum(dr.maximum(k + 1, last), dr.maximum(end, k + 1)), k + 1)

    def _bins(self, origins: list, directions: list, near: Float, dt: Float) -> tuple[UInt32, UInt32]:
        """Per ray, the first and one past the last bin that can be occupied: those whose centres lie in the
        box (slab test), with a bin of margin; none where the ray misses it."""
        t_in, t_out, D = Float(-np.inf), Float(np.inf), len(origins)
        for a, (o, d) in enumerate(zip(origins, directions)):
            lo, hi = dr.gather(Float, self.box, UInt32(a)), dr.gather(Float, self.box, UInt32(a + D))
            inv = 1.0 / dr.select(dr.abs(d) > 1e-12, d, 1e-12)
            t1, t2 = (lo - o) * inv, (hi - o) * inv
            t_in = dr.maximum(t_in, dr.select(lo <= hi, dr.minimum(t1, t2), np.inf))        # lo > hi: no cell
            t_out = dr.minimum(t_out, dr.maximum(t1, t2))
        first = dr.clip(dr.floor((t_in - near) / dt) - 1.0, 0.0, self.bins)
        last = dr.clip(dr.ceil((t_out - near) / dt) + 1.0, 0.0, self.bins)
        return UInt32(first), UInt32(dr.select(t_in <= t_out, last, first))

    def _groups(self, K: UInt32) -> tuple[UInt32, UInt32]:
        """``(stride, groups)`` of rays with ``K`` occupied bins: ``stride = ceil(K / n)`` bins a sample, and the
        samples (slots used) that makes."""
        stride = dr.maximum((K + (self.n - 1)) // self.n, 1)
        return stride, (K + stride - 1) // stride

    def _place(self, lanes: tuple, end: UInt32, K: UInt32 | None, *, clear: bool) -> UInt32:
        """Place the samples of the lanes' bins ``[first, end)``: given their ``K`` occupied bins, one per group of
        ``stride = ceil(K / n)``, and with ``clear`` the slots past the groups (which a first pass filled) emptied
        again; without ``K`` (None), one in each of the first ``n`` occupied bins. Returns the occupied bins
        passed."""
        o, d, ray, first, near_r, far_r, dt, t_out, d_out = lanes
        stride, groups = (None, None) if K is None else self._groups(K)
        faces = None if clear else self._faces(d, dt)

        def place_body(k, rank):
            occ, x, _, inside, coords = self._bin_occupied(o, d, k, near_r, far_r)
            j = rank if stride is None else rank // stride
            take = occ & (j < self.n)
            if stride is not None:
                take &= rank % stride == 0
            u = uniform(self.seed, ray, k) if self.jitter else Float(0.5)
            group = 1 if stride is None else dr.minimum(stride, K - rank)      # the last group may hold fewer
            t, delta = self._at(Float(k) + u, near_r, far_r), self._span(k, group, near_r, far_r, dt)
            dr.scatter(t_out, t, ray * self.n + j, take)
            dr.scatter(d_out, delta, ray * self.n + j, take)
            if clear:               # K > n: more bins than slots, so each bin visited can empty one slot
                c = groups + (k - first)
                dr.scatter(t_out, far_r, ray * self.n + c, c < self.n)
                dr.scatter(d_out, 0.0, ray * self.n + c, c < self.n)
                return k + 1, rank + dr.select(occ, 1, 0)       # a slot per bin: every bin is visited
            return self._next_bin(faces, k, x, coords, inside & ~occ, end), rank + dr.select(occ, 1, 0)

        _, rank = dr.while_loop((UInt32(first), dr.zeros(UInt32, dr.width(ray))), lambda k, r: k < end, place_body,
                                label="occupancy_place")
        return rank

    def build(self, origins: list, directions: list, near, far) -> Explicit:
        """Place the samples of every ray: an :class:`~.samplers.Explicit` with intervals and a count."""
        n_rays = dr.width(origins[0])
        ray = dr.arange(UInt32, n_rays)
        near_r, far_r = per_sample(Float(near), ray), per_sample(Float(far), ray)
        dt = (far_r - near_r) * (1.0 / self.bins)
        if self.space.warped:                     # rays curve in the warped space: no world box to clip them to
            first, end = dr.zeros(UInt32, n_rays), dr.full(UInt32, self.bins, n_rays)
        else:
            first, end = self._bins(origins, directions, near_r, dt)
        order = None
        if self.grouped and not self.space.warped:
            ray = order = grouped(end - first, self.bins)       # lane -> ray
            first, end = dr.gather(UInt32, first, ray), dr.gather(UInt32, end, ray)
            near_r, far_r, dt = (per_sample(v, ray) for v in (near_r, far_r, dt))

        # unused slots: t = far, delta = 0 (no contribution)
        if self.fill:
            t_out = dr.gather(Float, per_sample(Float(far), dr.arange(UInt32, n_rays)),
                              dr.arange(UInt32, n_rays * self.n) // self.n)
            d_out = dr.zeros(Float, n_rays * self.n)
        else:
            t_out, d_out = dr.empty(Float, n_rays * self.n), dr.empty(Float, n_rays * self.n)
        o, d = in_lanes(origins, order), in_lanes(directions, order)      # the lanes' rays, gathered once
        lanes = (o, d, ray, first, near_r, far_r, dt, t_out, d_out)
        if self.density is None or self.early_stop <= 0.0:
            # one pass places a sample in each of the first n occupied bins while it counts them: every ray with
            # at most n (stride 1); the others are placed again, grouped
            K = self._place(lanes, end, None, clear=False)
            dr.eval(K)                                  # else the second pass's kernel runs the first pass again
            self._place(lanes, dr.select(K > self.n, end, first), K, clear=True)
        else:
            tau_end, faces = float(-np.log(self.early_stop)), self._faces(d, dt)

            def count_body(k, count, tau):
                occ, x, stretch, inside, coords = self._bin_occupied(o, d, k, near_r, far_r)
                width = self._span(k, 1, near_r, far_r, dt) * stretch
                sigma = dr.if_stmt((x,), occ, lambda x: dr.detach(self.density(x)),     # gathers of occupied bins
                                   lambda x: dr.zeros(Float, dr.width(x[0])), label="early_stop")
                return (self._next_bin(faces, k, x, coords, inside & ~occ, end), count + dr.select(occ, 1, 0),
                        tau + dr.maximum(sigma, 0.0) * width)

            end, K, _ = dr.while_loop((UInt32(first), dr.zeros(UInt32, n_rays), dr.zeros(Float, n_rays)),
                                      lambda k, c, tau: (k < end) & (tau < tau_end), count_body,
                                      label="occupancy_count")
            self._place(lanes, end, K, clear=False)
        count = dr.zeros(UInt32, n_rays)
        dr.scatter(count, self._groups(K)[1], ray, mode=dr.ReduceMode.Permute)
        return Explicit(t_out, self.n, d_out, count, filled=self.fill)
