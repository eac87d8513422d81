"""mitnerf: fast, honest NeRF experiments on a CPU.

Importing the package has no side effects. Entry points choose Mitsuba's variant with
:func:`set_variant` (``llvm_ad_rgb`` unless ``$MITNERF_VARIANT`` says otherwise); library
code that needs Mitsuba picks the default if nobody chose.

Stages of the data flow, one sub-package each, each importing only the ones before it::

    scenes -> data -> fields -> render -> train -> experiments -> cli
                      (reference: the PyTorch twins, same names; imported by the torch backend)
"""

from ._variant import set_variant
from .errors import MitnerfError

__version__ = "0.2.0"

__all__ = ["MitnerfError", "set_variant", "__version__"]
