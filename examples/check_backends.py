"""Cross-backend check: the custom volume integral (every field mode), Dr.Jit's plain AD and the
PyTorch twin on the same weights, rays and random cotangents (:mod:`mitnerf.reference.parity`).
Prints the max abs and relative error of every output and gradient, a finite-difference check and
a final pass/fail line; exits 1 on failure.

    python examples/check_backends.py [--field vanilla|grid|hashgrid|hashlinear] [--dim 2|3] [--rays 64]
                                      [--samples 32] [--fine 16] [--width 16] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys

from mitnerf.reference.parity import FIELD_ARGS, TOL_FD, check_parity


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--field", choices=list(FIELD_ARGS), default="vanilla")
    p.add_argument("--dim", type=int, choices=[2, 3], default=2)
    for name, default in (("rays", 64), ("samples", 32), ("fine", 16), ("width", 16), ("seed", 0)):
        p.add_argument(f"--{name}", type=int, default=default)
    args = p.parse_args(argv)
    r = check_parity(**vars(args))
    print(f"field {args.field}, {args.dim}D")
    print(f"{'quantity':<22}" + "".join(f"{k:>28}" for k in r.paths))
    for prefix, errors, kind in (("", r.values, "abs"), ("d/d ", r.grads, "rel")):
        for key, es in errors.items():
            print(f"{prefix + key:<22}" + "".join(f"{e:>19.2e} {kind}     " for e in es))
    print(f"finite differences (custom op vs central, fp32): worst relative error {r.fd:.2e} (tolerance {TOL_FD:g})")
    print("check_backends: PASS" if r.ok else "check_backends: FAIL")
    return 0 if r.ok else 1


if __name__ == "__main__":
    sys.exit(main())
