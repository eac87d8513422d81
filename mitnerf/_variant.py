"""Mitsuba variant selection and the LLVM version guard.

``import mitnerf`` selects ``llvm_ad_rgb`` unless ``MITNERF_VARIANT`` names another
variant (for example ``cuda_ad_rgb`` where a GPU exists). Dr.Jit 1.5 emits
``llvm.maximum`` for ``dr.maximum``; LLVM 15 cannot compile it and aborts the process,
so the LLVM backend is refused on LLVM < 16 before any kernel is built.
"""

from __future__ import annotations

import os

DEFAULT_VARIANT = "llvm_ad_rgb"
MIN_LLVM = 16


class LLVMTooOldError(ImportError):
    pass


def check_llvm() -> tuple[int, int, int]:
    """Raise one line that says how to fix it when Dr.Jit's LLVM is missing or < 16."""
    import drjit as dr

    version = tuple(dr.detail.llvm_version())
    if version[0] < MIN_LLVM:
        found = "no LLVM" if version[0] < 0 else "LLVM %d.%d.%d" % version
        raise LLVMTooOldError(
            f"mitnerf needs LLVM >= {MIN_LLVM} for Dr.Jit's LLVM backend but found {found}: "
            "run `apt-get install -y libllvm19` (or `make setup`), or set "
            "DRJIT_LIBLLVM_PATH to a libLLVM.so of version >= 16."
        )
    return version


def select_variant(name: str | None = None) -> str:
    """Select a Mitsuba variant: ``name``, else ``$MITNERF_VARIANT``, else the variant the
    caller already set, else ``llvm_ad_rgb``."""
    import mitsuba as mi

    name = name or os.environ.get("MITNERF_VARIANT") or mi.variant() or DEFAULT_VARIANT
    if name.startswith("llvm"):
        check_llvm()
    if name not in mi.variants():
        raise ImportError(
            f"Mitsuba variant {name!r} is not available (have {', '.join(mi.variants())}): "
            "set MITNERF_VARIANT to one of them."
        )
    mi.set_variant(name)
    return name
