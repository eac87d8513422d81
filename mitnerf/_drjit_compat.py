"""Every workaround for Dr.Jit 1.5.0 (with Mitsuba 3.9.1) in one place: each function says what it works around
and the upstream issue it waits for; drop one when the pinned Dr.Jit carries the fix.

Avoided rather than worked around: a training step through ``nn.HashGridEncoding`` cannot be recorded with
``dr.freeze`` (it aborts as in :func:`freeze`), so the hash grid encodes with :mod:`mitnerf.fields.hashenc`, the
same function in scalar gathers; and its ``params`` setter raises ``TypeError`` (it calls
``self.set_params(self, values)``). No upstream issue found for either.
"""

from __future__ import annotations

import gc

from .errors import EnvironmentProblem

MIN_LLVM = 16


def check_llvm() -> tuple[int, int, int]:
    """Raise one line that says how to fix it when Dr.Jit's LLVM is missing or older than 16: ``dr.maximum`` and
    ``dr.minimum`` on floats emit ``llvm.maximum``, which LLVM 15 cannot select on x86 (``LLVM ERROR: Cannot
    select: fmaximum`` aborts the process). Upstream: llvm/llvm-project#53353 (lowered since LLVM 16); no Dr.Jit
    issue found."""
    import drjit as dr

    version = tuple(dr.detail.llvm_version())
    if version[0] < MIN_LLVM:
        found = "no LLVM" if version[0] < 0 else "LLVM %d.%d.%d" % version
        raise EnvironmentProblem(f"mitnerf needs LLVM >= {MIN_LLVM} for Dr.Jit's LLVM backend but found {found}: "
                                 "run `apt-get install -y libllvm19` (or `make setup`), or set DRJIT_LIBLLVM_PATH "
                                 "to a libLLVM.so of version >= 16.")
    return version


def set_learning_rate(opt, lr) -> None:
    """Give every parameter of ``opt`` the learning rate ``lr`` (an opaque ``Float``: a new value needs no new
    kernel), each its own copy: ``drjit.opt`` folds the bias correction into an array-valued rate in place
    (``_LRCache.product``: ``scale_o *= arg``), so one shared array would compound. Upstream:
    mitsuba-renderer/drjit#540 (an open pull request)."""
    from drjit.auto.ad import Float

    opt.set_learning_rate({k: Float(lr) for k in opt.keys()})


def freeze(step):
    """``step`` recorded once with ``dr.freeze`` (every input opaque from the first recording on) and replayed.
    Replaying a recording after its inputs changed shape twice segfaults: call again for a new recording whenever
    shapes change. The garbage collector freeing Dr.Jit arrays while a function records aborts
    (``enqueue_host_func(): this function cannot be recorded``): each call runs with it off. No upstream issue
    found for either."""
    import drjit as dr

    gc.collect()
    frozen = dr.freeze(step, auto_opaque=False)

    def call(*args):
        enabled = gc.isenabled()
        gc.disable()
        try:
            return frozen(*args)
        finally:
            if enabled:
                gc.enable()

    return call
