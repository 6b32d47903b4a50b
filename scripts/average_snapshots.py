"""Average the F and actor weights of several snapshots of one FB run (weight averaging,
as in SWA). Only meaningful when B is shared, i.e. after `freeze_b_step`: every tensor
outside F and the actor (B, its batch-norm statistics, Cov B, input statistics) must be
identical across the snapshots, or the script stops.

Usage: python scripts/average_snapshots.py --out DIR SNAPSHOT [SNAPSHOT ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from fbil.errors import FbilError
from fbil.fb.model import FBModel

AVERAGED = ("forward_net.", "actor.")


def average(snapshots: list[Path]) -> FBModel:
    models = [FBModel.load(s) for s in snapshots]
    if any(m.config != models[0].config for m in models):
        raise FbilError("the snapshots have different model configs; pass snapshots of one run")
    states = [m.state_dict() for m in models]
    mean = {}
    for key, last in states[-1].items():
        if key.startswith(AVERAGED) and last.is_floating_point():
            mean[key] = torch.stack([s[key] for s in states]).mean(0)
        elif all(torch.equal(s[key], last) for s in states):
            mean[key] = last
        else:
            raise FbilError(
                f"{key} differs between snapshots; average only snapshots taken after "
                "freeze_b_step (B must be shared)"
            )
    out = models[-1]
    out.load_state_dict(mean)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("snapshots", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    try:
        if args.out.exists():
            raise FbilError(f"{args.out} exists; choose a new --out")
        model = average(args.snapshots)
        model.save(args.out, extra={"averaged_snapshots": [str(s) for s in args.snapshots]})
    except FbilError as exc:
        sys.exit(f"error: {exc}")
    print(f"averaged {len(args.snapshots)} snapshots into {args.out}")


if __name__ == "__main__":
    main()
