"""PyTorch twins of the Dr.Jit operations, under the same names and module paths, computing the same
functions in the same order, so outputs and gradients can be compared (:mod:`mitnerf.reference.parity`).
Requires the ``torch`` extra (``torch==2.13.0``, the CPU wheel).
"""
