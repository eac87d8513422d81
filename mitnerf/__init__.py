"""mitnerf: fast, honest NeRF experiments on a CPU.

Importing has no side effects; entry points choose Mitsuba's variant with :func:`set_variant` (``llvm_ad_rgb``
unless ``$MITNERF_VARIANT`` says otherwise); library code that needs Mitsuba picks the default if nobody chose.
Stages, one sub-package each, each importing only the ones before it (reference: the PyTorch twins)::

    scenes -> data -> fields -> render -> train -> experiments -> cli
"""

from ._variant import set_variant
from .errors import MitnerfError

__version__ = "0.2.0"

__all__ = ["MitnerfError", "set_variant", "__version__"]
