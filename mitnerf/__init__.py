"""mitnerf: fast, honest NeRF experiments on a CPU.

Importing the package selects the Mitsuba variant (``llvm_ad_rgb`` unless
``$MITNERF_VARIANT`` says otherwise) and refuses an LLVM older than 16.

Stages of the data flow, one sub-package each::

    scenes  ->  data  ->  fields  ->  render  ->  train  ->  experiments
                                   (reference: the PyTorch twins, same names)
"""

from ._variant import LLVMTooOldError, select_variant
from .errors import MitnerfError

__version__ = "0.1.0"
try:
    variant = select_variant()
except LLVMTooOldError as exc:  # one line, no traceback: the message says how to fix it
    raise SystemExit(f"mitnerf: {exc}") from None

__all__ = ["MitnerfError", "select_variant", "variant", "__version__"]
