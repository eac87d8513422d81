"""The Dr.Jit engine: ``drjit.opt.Adam`` and one step (batch, render, loss, backward, Adam) recorded
once with ``dr.freeze`` (:func:`mitnerf._drjit_compat.freeze`) and replayed, up to :data:`FREEZE_MAX_PARAMS`
parameters; values that change between steps enter as opaque arrays."""

from __future__ import annotations

import contextlib

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32

from .._drjit_compat import check_llvm, freeze, set_learning_rate
from ..fields import make_field
from ..render.occupancy import OccupancyGrid
from ..render.pipeline import Model, final
from ..rng import uniform
from . import losses
from .adam import LeanAdam
from .backend import SOLID_SALT, Backend, behind_depth, model_fields, training_loss


def columns(a: np.ndarray) -> list:
    """``[n, C]`` numpy -> C Dr.Jit arrays ``[n]``."""
    return [Float(np.ascontiguousarray(c, dtype=np.float32)) for c in np.asarray(a).T]


FREEZE_MAX_PARAMS = 1 << 24
"""Parameters above which a step is traced anew each time rather than replayed: a replay zero-fills and then copies
each parameter's gradient, passes over memory (and a peak) that a traced step does not have (Dr.Jit 1.5); past
about 16 M parameters they cost more than tracing the step does (the lego's grid: ``benchmarks/lego.py``)."""

LEAN_ADAM_ABOVE = 60_000_000
"""Parameters above which Adam's step evaluates one array at a time (:class:`~.adam.LeanAdam`): two copies of the
parameters fewer at the step's peak, for two more passes over them. The recipes' own lattices stay below it and keep
Adam's one launch, the faster; a finer lattice asked for (``--set resolution=...``) is where memory binds first
(``benchmarks/adam_step.py`` measures both steps on the lego's lattices)."""

EXPAND_BYTES = 1 << 30
"""Memory the gradient of one array may take in copies during a training step. Within a step, every array of at
most :func:`expand_threshold` floats that a scatter-add of the backward pass writes (a parameter array's gradient,
above all) gets one copy per thread and one more (Dr.Jit's ``ReduceMode.Expand``, which its ``Auto`` mode picks for
arrays under ``dr.expand_threshold()``): the scatter-adds into it then go without atomic operations, and the copies
are summed once after the pass. Larger arrays keep Dr.Jit's atomic adds (and
:attr:`~mitnerf.fields.base.Field.scattered`'s choice for them). The threshold holds only inside the step
(:func:`expanding`); 0: Dr.Jit's own. ``benchmarks/scatter.py`` measures the steps a second and the peak memory this
buys on the lego's dense lattice and on ``hashgrid-3d``'s table."""
DRJIT_EXPAND_THRESHOLD = 1 << 20
"""Dr.Jit's own ``dr.expand_threshold()`` (floats): the least this engine sets."""


def expand_threshold(threads: int) -> int:
    """Floats up to which an array's gradient gets a copy per thread and one more (:data:`EXPAND_BYTES`)::

        expand_threshold(2)     # 89478485 with EXPAND_BYTES = 1 GiB: 3 copies of 4-byte floats fill it
    """
    return max(DRJIT_EXPAND_THRESHOLD, EXPAND_BYTES // (4 * (max(1, threads) + 1)))


@contextlib.contextmanager
def expanding(threshold: int):
    """Dr.Jit's expansion threshold at ``threshold`` floats within, restored after (a process-wide setting)."""
    before = dr.expand_threshold()
    dr.set_expand_threshold(threshold)
    try:
        yield
    finally:
        dr.set_expand_threshold(before)


CHECK_EVERY = 16
"""Steps between the checks that every parameter is finite: a non-finite gradient makes its parameter so in Adam's
step, and a run that fails restores its last good validation's weights, so a check a few steps late loses
nothing, where a check every step would read every parameter every step."""

STEP_INPUTS = ("origins", "directions", "target", "background", "depth", "hit", "free", "footprint", "solid")
"""What a step reads of its batch (:class:`~mitnerf.data.rays.RaySet`)."""


def build_model(cfg, dim: int, bound: float) -> Model:
    return Model(model_fields(cfg, dim, bound, make_field), cfg.render)


RENDER_CHUNK = 1 << 17
"""Rays a render launches at once through a traceable field. The occupancy sampler and the deferred colour
(:mod:`mitnerf.render.deferred`) hold four numbers per sample slot of each: ``16 N`` bytes a ray for ``N`` slots,
512 MiB a chunk for the lego's 256 (64 samples, four times over in renders). Kernels over this many rays keep both
threads busy."""


class DrJitBackend(Backend):
    name = "drjit"

    def __init__(self, model_cfg, train_cfg, dim, bound, near, far):
        super().__init__(model_cfg, train_cfg, dim, bound, near, far)
        check_llvm()
        dr.set_thread_count(train_cfg.threads)
        self.model = build_model(model_cfg, dim, bound)
        self.chunk = RENDER_CHUNK if self.model.fields["coarse"].traceable else 8192
        self.opt = LeanAdam(lr=train_cfg.lr, beta_1=train_cfg.beta1, beta_2=train_cfg.beta2, epsilon=train_cfg.eps,
                            params=self.model.init_params(train_cfg.seed), lean_above=LEAN_ADAM_ABOVE)
        occ = model_cfg.render.occupancy
        self.occupancy = OccupancyGrid(occ, dim, bound) if occ.enabled else None
        self._inputs = None
        """The batch, column after column (``STEP_INPUTS``), in one array written in place every step: a frozen
        step given fresh arrays each time is recorded again and again while earlier steps are in flight."""
        self._reads = 0
        """Steps read so far (:meth:`read` checks the parameters every :data:`CHECK_EVERY`-th)."""
        self.replayed = False
        """Whether the step is recorded once and replayed (``dr.freeze``), not traced each time
        (:data:`FREEZE_MAX_PARAMS`); set with each new step."""
        self._frozen = self._new_step()

    @property
    def params(self) -> dict:
        return {k: self.opt[k] for k in self.opt.keys()}

    def detached(self) -> dict:
        """The parameters without gradients, at the step reached (:meth:`Model.at_step`)."""
        return self.model.at_step({k: dr.detach(v) for k, v in self.params.items()},
                                  None if self.step_reached is None else dr.opaque(Float, self.step_reached))

    def _new_step(self):
        # no reference to the backend in the closure: the cyclic GC could free it while a frozen call records
        model, cfg, n_final = self.model, self.cfg, self.n_final
        near, far, B = self.near, self.far, cfg.batch_rays
        use_weights, jitter, D = cfg.needs_weights, self.model_cfg.render.pixel_jitter, self.dim
        mining = cfg.mining > 0
        names = STEP_INPUTS + (("weight",) if mining else ())      # a mined batch's loss weights last
        widths = [D, D, 3, 3, 1, 1, 1, 2 * D, 1, 1][:len(names)]

        local = not all(f.scattered for f in model.fields.values())     # see Field.scattered
        threshold = expand_threshold(cfg.threads)

        def step(opt, inputs, seed, lr, index, occupancy):
            with dr.scoped_set_flag(dr.JitFlag.ScatterReduceLocal, local), expanding(threshold):
                return traced(opt, inputs, seed, lr, index, occupancy)

        def traced(opt, inputs, seed, lr, index, occupancy):
            set_learning_rate(opt, lr)
            rows, data = dr.arange(UInt32, B), {}
            for k, start, width in zip(names, np.cumsum([0, *widths]).tolist(), widths):  # the batch's columns
                data[k] = [dr.gather(Float, inputs, rows + (start + c) * B) for c in range(width)]
            params = model.at_step({k: opt[k] for k in opt.keys()}, index)
            o = data["origins"]
            d = d_centre = data["directions"]
            if jitter:                  # a ray through a random point of the pixel (twin: backend.jitter_np)
                a, b = (uniform(seed ^ 0x68E31DA4, dr.arange(UInt32, B), UInt32(k)) - 0.5 for k in (0, 1))
                fp = data["footprint"]
                d = [d[i] + a * fp[i] + b * fp[D + i] for i in range(D)]
                inv = dr.rsqrt(sum(di * di for di in d))
                d = [di * inv for di in d]
            # the terms that read parameters at scattered points before the render: their gradients, scatters into
            # new arrays, come first in the backward pass and the integral's is added to them; the other way round
            # an atomic scatter would copy the integral's whole gradient first (tests/test_training.py; a gradient
            # summed in copies per thread, EXPAND_BYTES, is copied once in its expansion either way)
            reg = model.regularizer(params, seed)
            depth, behind = data["depth"][0], None
            if cfg.solid_weight > 0:            # points within the solid extent behind pixel-centre depths
                extent = data["solid"][0]
                u = uniform(seed ^ SOLID_SALT, dr.arange(UInt32, B), UInt32(0))
                t = behind_depth(u, depth, extent, cfg.solid_start)
                behind = (model.density(params, [oi + t * di for oi, di in zip(o, d_centre)]),
                          dr.select(extent > 0, 1.0, 0.0))
            outs = model.render(params, o, d, near, far, seed, training=True, weights=use_weights,
                                occupancy=occupancy, background=data["background"])
            weight = data["weight"][0] if mining else None
            loss = training_loss(cfg, n_final, losses, outs, data["target"], depth, data["hit"][0],
                                 data["free"][0], behind, reg, weight)
            dr.backward(loss)
            opt.step()
            if not mining:
                return loss
            final = outs["fine"] if outs.get("fine") is not None else outs["coarse"]
            return loss, losses.rms_error(final.rgb, data["target"])

        self.replayed = (cfg.freeze and all(f.freezable for f in model.fields.values())
                         and self.n_params() <= FREEZE_MAX_PARAMS)
        return freeze(step) if self.replayed else step

    def step(self, index: int, seed: int, lr: float):
        new = self.model.schedule(index, self.params)
        if new:
            self.opt.update(new)    # a resized parameter also resets its Adam state
            self._frozen = self._new_step()         # new shapes: a new recording (see _drjit_compat.freeze)
        self.update_occupancy(index, seed)
        occ, b = self.occupancy, self.batch(seed)
        columns = [getattr(b, k).reshape(len(b), -1).T.ravel() for k in STEP_INPUTS]
        batch = np.concatenate(columns if self.errors is None else columns + [self.drawn[1]])
        if self._inputs is None or dr.width(self._inputs) != len(batch):
            self._inputs = dr.zeros(Float, len(batch))
        dr.eval(self._inputs)
        dr.sync_thread()                # the steps in flight have read the last batch
        self._inputs.numpy()[:] = batch
        self.step_reached = index
        for _, _, _, (t, *_) in self.opt.state.values():
            dr.make_opaque(t)           # Adam's step count: a literal would be baked into every step's kernels
        out = self._frozen(self.opt, self._inputs, dr.opaque(UInt32, seed), dr.opaque(Float, lr),
                           dr.opaque(Float, index), occ.lookup if occ is not None else None)
        if isinstance(out, tuple):                  # mined: the rays' errors for the map (Backend.mined)
            out, error = out
            self.mined(error)
        return out

    def release(self) -> None:
        dr.sync_thread()
        dr.flush_malloc_cache()

    def read(self, handle) -> tuple[float, str | None]:
        """The loss of a step, and the first parameter that is not finite, looked for in every
        :data:`CHECK_EVERY`-th read (a pass over all of them) and wherever the loss is not finite."""
        value = float(handle[0])
        self._reads += 1
        if np.isfinite(value) and self._reads % CHECK_EVERY:
            return value, None
        return value, next((f"parameter {k}" for k, v in self.params.items()
                            if not dr.all(dr.isfinite(v.array if dr.is_tensor_v(v) else v))), None)

    def _density_fn(self):
        params = self.detached()
        return lambda x: self.model.density(params, x)

    def render_chunk(self, origins: np.ndarray, directions: np.ndarray) -> dict:
        with dr.suspend_grad():
            occ = self.occupancy.lookup if self.occupancy is not None else None
            out = final(self.model.render(self.detached(), columns(origins), columns(directions), self.near,
                                          self.far, UInt32(0), training=False, occupancy=occ))
            dr.eval(out.rgb, out.depth, out.opacity)
            return {"rgb": np.stack([np.asarray(c) for c in out.rgb], 1), "depth": np.asarray(out.depth),
                    "opacity": np.asarray(out.opacity)}

    def density(self, x: np.ndarray) -> np.ndarray:
        with dr.suspend_grad():
            return np.asarray(self.model.density(self.detached(), columns(np.asarray(x, np.float32))))

    def model_weights(self) -> dict[str, np.ndarray]:
        return self.model.to_numpy(self.params)

    def load_model_weights(self, arrays: dict[str, np.ndarray]) -> None:
        self.opt.update(self.model.from_numpy(arrays))
        self._frozen = self._new_step()             # shapes may have changed (a resized grid)

    def optimizer_state(self) -> dict[str, np.ndarray]:
        out = {}
        for k, (_, _, _, (t, m, v, _)) in self.opt.state.items():
            out[f"{k}.t"] = np.array(t, np.uint32).reshape(-1)
            dr.eval(m, v)
            out[f"{k}.m"], out[f"{k}.v"] = self.model.saved(k, m), self.model.saved(k, v)    # views, not copies
        return out

    def load_optimizer_state(self, arrays: dict[str, np.ndarray]) -> None:
        for k, (value, promoted, lr, (t, m, v, vmax)) in list(self.opt.state.items()):
            if f"{k}.m" not in arrays:
                continue
            M, V = (type(x)(self.model.stored(k, arrays[f"{k}.{s}"])) for x, s in ((m, "m"), (v, "v")))
            self.opt.state[k] = (value, promoted, lr, (type(t)(int(arrays[f"{k}.t"][0])), M, V, vmax))
