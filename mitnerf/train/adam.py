"""Adam with a lean step: ``drjit.opt.Adam``'s arithmetic, evaluated one array at a time.

``drjit.opt.Adam.step`` builds every parameter's new first moment ``m``, second moment ``v`` and value ``x`` and
evaluates them all in one launch, so each old array is still alive when its successor is written: with the gradient
``g``, seven arrays the size of the parameters at once (``x, m, v, g`` and the three new ones). :class:`LeanAdam`
evaluates, for one parameter at a time, ``m`` (the old ``m`` is then released), ``v`` (into the old ``m``'s memory,
which Dr.Jit's allocator keeps for reuse), drops the gradient, then ``x`` (into the old ``v``'s): two arrays the size
of the parameters fewer at the step's peak. The values are the same to the bit; the price is
two more passes over the parameters (``m`` and ``v`` written, then read back). The engine takes it for the
largest models only (:data:`~mitnerf.train.backend_drjit.LEAN_ADAM_ABOVE`; ``benchmarks/adam_step.py`` measures
both steps on the lego's grid); ``tests/test_adam.py`` checks the values and the memory.
"""

from __future__ import annotations

import drjit as dr
from drjit.opt import Adam, _LRCache


class LeanAdam(Adam):
    """``drjit.opt.Adam`` whose :meth:`step` holds at most one new array beside the old ones (module docstring)
    where the parameters number more than ``lean_above`` (fewer: Adam's one launch, the faster for them). With
    ``mask_updates``, ``amsgrad``, ``grad_scale`` or ``active``, the step is Adam's own."""

    def __init__(self, *args, lean_above: int = 0, **kwargs):
        super().__init__(*args, **kwargs)
        self.lean_above = lean_above
        """Parameters (all of them, counted) above which :meth:`step` is lean."""

    def step(self, *, eval: bool = True, grad_scale=None, active=None) -> None:  # noqa: A002 (Adam's name)
        size = sum(dr.width(value.array) for value, *_ in self.state.values())
        if size <= self.lean_above or not eval or grad_scale is not None or active is not None or \
                self.mask_updates or self.amsgrad:
            return super().step(eval=eval, grad_scale=grad_scale, active=active)
        cache = _LRCache()
        for key in list(self.state):
            value, promoted, rate, extra = self.state[key]
            grad = value.grad.array
            new, (t, m, v, v_max) = self._step(cache, dr.detach(value).array, grad, self.lr if rate is None else rate,
                                               extra)
            # the old moments' last references are now the new moments' expressions: evaluating each releases it
            self.state[key] = value, promoted, rate, (t, m, v, v_max)
            del extra
            dr.eval(t, m)
            dr.eval(v)
            del grad
            dr.clear_grad(value)                # the gradient's memory, before the new value takes some
            dr.eval(new)
            tp = type(value)
            if type(new) is not tp:
                new = tp(new, value.shape) if dr.is_tensor_v(tp) else tp(new)
            dr.enable_grad(new)
            self.state[key] = new, promoted, rate, (t, m, v, v_max)
