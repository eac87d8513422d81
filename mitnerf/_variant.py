"""Choosing Mitsuba's variant (called by entry points, never on import), with the LLVM guard
(:func:`mitnerf._drjit_compat.check_llvm`)."""

from __future__ import annotations

import os

from ._drjit_compat import check_llvm
from .errors import EnvironmentProblem

DEFAULT_VARIANT = "llvm_ad_rgb"


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
