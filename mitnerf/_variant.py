"""Choosing Mitsuba's variant, and the LLVM guard (called by entry points, never on import): Dr.Jit 1.5
emits ``llvm.maximum``, which LLVM 15 cannot compile (it aborts), so the LLVM backend needs LLVM >= 16."""

from __future__ import annotations

import os

from .errors import EnvironmentProblem

DEFAULT_VARIANT = "llvm_ad_rgb"
MIN_LLVM = 16


def check_llvm() -> tuple[int, int, int]:
    """Raise one line that says how to fix it when Dr.Jit's LLVM is missing or older than 16."""
    import drjit as dr

    version = tuple(dr.detail.llvm_version())
    if version[0] < MIN_LLVM:
        found = "no LLVM" if version[0] < 0 else "LLVM %d.%d.%d" % version
        raise EnvironmentProblem(f"mitnerf needs LLVM >= {MIN_LLVM} for Dr.Jit's LLVM backend but found {found}: "
                                 "run `apt-get install -y libllvm19` (or `make setup`), or set DRJIT_LIBLLVM_PATH "
                                 "to a libLLVM.so of version >= 16.")
    return version


def set_variant(name: str | None = None) -> str:
    """Select a Mitsuba variant: ``name``, else ``$MITNERF_VARIANT``, else ``llvm_ad_rgb``.
    Returns the variant's name; raises :class:`EnvironmentProblem` when it cannot be used."""
    import mitsuba as mi

    name = name or os.environ.get("MITNERF_VARIANT") or DEFAULT_VARIANT
    if name.startswith("llvm"):
        check_llvm()
    if name not in mi.variants():
        raise EnvironmentProblem(f"Mitsuba variant {name!r} is not available (have {', '.join(mi.variants())}): "
                                 "set MITNERF_VARIANT to one of them.")
    mi.set_variant(name)
    return name


def ensure_variant() -> str:
    """The variant already chosen, or the default one chosen now (library code that needs
    Mitsuba calls this, so that a script that never chose still works)."""
    import mitsuba as mi

    return mi.variant() or set_variant()
