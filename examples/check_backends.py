"""Cross-backend check: the custom volume integral (every field mode), Dr.Jit's plain AD and the
PyTorch twin on the same weights, rays and random cotangents (:mod:`mitnerf.reference.parity`).
Prints the max abs and relative error of every output and gradient, a finite-difference check and
a final pass/fail line; exits 1 on failure.

    python examples/check_backends.py [--field vanilla|grid|hashgrid|hashlinear] [--dim 2|3] [--rays 64]
                                      [--samples 32] [--fine 16] [--width 16] [--seed 0]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

from mitnerf.reference.parity import FIELD_ARGS, ParityCase, check_parity


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--field", choices=list(FIELD_ARGS), default="vanilla")
    p.add_argument("--dim", type=int, choices=[2, 3], default=2)
    for f in dataclasses.fields(ParityCase):
        if f.name not in ("field", "dim"):
            p.add_argument(f"--{f.name}", type=int, default=f.default)
    case = ParityCase(**vars(p.parse_args(argv)))
    result = check_parity(case)
    print(f"field {case.field}, {case.dim}D")
    print("\n".join(result.lines()))
    print("check_backends: PASS" if result.ok else "check_backends: FAIL")
    return 0 if result.ok else 1


if __name__ == "__main__":
    sys.exit(main())
