"""Does a gradient FB-IL method's z fit the demonstration better than ERFB's, by the model's
own losses? For each task's first committed demonstration, print the FMFB and DMFB losses
(`fbil.imitation.methods.matching`) at the z of each named method, and each z's cosine
with ERFB's (the gradient methods' warm start).

If an optimised z has a much lower loss than ERFB's z yet its policy scores lower in the
grids, F's prediction of what pi_z visits is what misleads the optimiser (the model is the
bound), not the optimiser itself.

Usage: python scripts/z_loss_probe.py MODEL DEMOS_DIR [--tasks all] [--methods erfb,fmfb,...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from fbil.errors import FbilError
from fbil.fb.model import FBModel
from fbil.imitation.api import imitate
from fbil.imitation.core import prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods.matching import dm_loss, fm_loss


def probe(
    model: FBModel, demos: Demos, methods: list[str]
) -> list[tuple[str, float, float, float]]:
    """(method, FM loss, DM loss, cosine to ERFB's z) at the first demonstration."""
    one = Demos([demos.trajectories[0]], dict(demos.metadata))
    batch = prepare(model, one, model.gamma)
    zs = {m: imitate(model, one, m).z_at(0).reshape(-1) for m in ["erfb", *methods]}
    rows = []
    with torch.no_grad():
        for method in methods:
            z = zs[method]
            cos = torch.nn.functional.cosine_similarity(z, zs["erfb"], dim=0)
            fm, dm = fm_loss(model, batch, z[None]), dm_loss(model, batch, z[None])
            rows.append((method, float(fm), float(dm), float(cos)))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("demos")
    parser.add_argument("--tasks", default="all")
    parser.add_argument("--methods", default="erfb,fmfb,dmfb,bbellfb,fblossfb")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    try:
        model = FBModel.load(args.model)
        files = sorted(p for p in Path(args.demos).glob("*.npz") if "_shifted" not in p.stem)
        if args.tasks != "all":
            files = [p for p in files if p.stem in args.tasks.split(",")]
        if not files:
            raise FbilError(f"no demonstrations for {args.tasks!r} in {args.demos}")
        print("task            method    FM loss       DM loss     cos to erfb")
        for path in files:
            for method, fm, dm, cos in probe(model, Demos.load(path), args.methods.split(",")):
                print(f"{path.stem:15s} {method:8s} {fm:12.1f} {dm:12.1f}  {cos:8.3f}")
    except FbilError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
