"""PyTorch twins of the Dr.Jit operations, under the same names and module paths
(``mitnerf.fields.mlp.NeRFField`` <-> ``mitnerf.reference.fields.mlp.NeRFField``).
They compute the same functions in the same order, so outputs and gradients can be
compared with the same weights and inputs (``examples/check_backends.py``).
Requires the ``torch`` extra (``torch==2.13.0``, the CPU wheel).
"""
