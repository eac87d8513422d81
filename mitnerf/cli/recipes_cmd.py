"""``mitnerf recipes``: the recipes, their settings, and the figures measured for them."""

from __future__ import annotations

from ..results import load_results
from ..train.recipes import DEFAULT, RECIPES


def register(sub) -> None:
    p = sub.add_parser("recipes", help="list the training recipes with their measured figures")
    p.add_argument("--dim", type=int, choices=[2, 3], default=None, help="only the recipes for this dimension")
    p.set_defaults(run=run)


def run(args) -> int:
    results = load_results()
    for name, r in RECIPES.items():
        if args.dim and r.dim != args.dim:
            continue
        default = " [default]" if DEFAULT[r.dim] == name else ""
        print(f"{r.summary()}{default}\n    {r.about}")
        for key, entry in sorted(results.items()):
            if entry.get("recipe") == name:
                print(f"    measured: {entry['summary']} ({key}; `{entry['command']}`)")
    if not results:
        print("(no measured figures: results.json is missing; `make bench` writes it)")
    return 0
