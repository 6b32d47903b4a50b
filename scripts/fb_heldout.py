"""Does an FB model fit its training sample more tightly than the dynamics? (seconds, no
rollout)

For each MODEL (a saved model or snapshot folder), the FB measure loss is evaluated with the
model's own F and B as the target, on --batches batches drawn with a fixed seed (z's drawn
as in training, from the model's own training config) from the training data (--data) and
from held-out episodes of the same kind (--heldout):

  diag  d = E[F(s, a, z)^T B(s')]   the measure F puts on a transition's own next state
  fb    the whole measure loss (off-diagonal residual + diagonal term), as training logs it

and their ratio r = d_held / d_train. A model that memorises its sample puts more measure
on the training transitions' own next states than on new ones of the same process, so r
falls as training goes on; its level also carries any difference between the two samples,
so read the trend over snapshots of one run.

Usage: python scripts/fb_heldout.py MODEL [MODEL ...] --data DIR --heldout DIR
           [--batches 40] [--seed 0] [--json OUT]
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import sys
from pathlib import Path
from typing import Any

import torch

from fbil.checkpoint import atomic_write_text
from fbil.data import Dataset, load_dataset
from fbil.errors import FbilError
from fbil.fb.config import FBTrainConfig
from fbil.fb.model import FBModel
from fbil.fb.train import FBTrainer


def _train_config(model: FBModel) -> FBTrainConfig:
    """The training config saved with the model (z sampling, gamma, batch size)."""
    saved = model.metadata.get("train_config")
    if not isinstance(saved, dict):
        raise FbilError("this model records no train_config; was it trained by `fbil pretrain`?")
    known = {f.name for f in dataclasses.fields(FBTrainConfig)}
    return FBTrainConfig(**{k: v for k, v in saved.items() if k in known})


def measure_terms(
    model: FBModel, cfg: FBTrainConfig, data: Dataset, batches: int, seed: int
) -> dict[str, float]:
    """Mean diagonal term and measure loss of `model` (its own target) on `data`."""
    cfg = dataclasses.replace(cfg, seed=seed, nstep=1, q_loss_coef=0.0)
    trainer = FBTrainer(model.config, cfg, data)
    trainer.model = copy.deepcopy(model).eval()
    trainer.f_target = trainer.model.forward_net
    trainer.b_target = trainer.model.backward_net
    diag = loss = 0.0
    with torch.no_grad():
        for _ in range(batches):
            out = trainer.fb_losses(trainer.sample(), frozen=True)
            diag += -float(out["fb_diag"]) / 2  # fb_diag sums the two heads' -E[F^T B]
            loss += float(out["fb_loss"])
    return {"diag": diag / batches, "fb_loss": loss / batches}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("models", nargs="+", help="model or snapshot folders (one run's, in order)")
    p.add_argument("--data", required=True, help="the models' training dataset")
    p.add_argument("--heldout", required=True, help="held-out episodes of the same kind")
    p.add_argument("--batches", type=int, default=40, help="batches per model and dataset")
    p.add_argument("--seed", type=int, default=0, help="seed of the batches and z's")
    p.add_argument("--json", default=None, help="write the table here")
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    try:
        if args.batches < 1:
            raise FbilError(f"--batches must be >= 1, got {args.batches}")
        rows = []
        train = held = None
        for name in args.models:
            model = FBModel.load(name)
            if train is None:
                train = load_dataset(args.data, model.domain)
                held = load_dataset(args.heldout, model.domain)
            assert held is not None
            cfg = _train_config(model)
            t = measure_terms(model, cfg, train, args.batches, args.seed)
            h = measure_terms(model, cfg, held, args.batches, args.seed)
            rows.append({"model": name, "train": t, "heldout": h, "r": h["diag"] / t["diag"]})
            print(
                f"{name}: diag train {t['diag']:.3f} held-out {h['diag']:.3f} "
                f"r {rows[-1]['r']:.3f}; fb loss train {t['fb_loss']:.1f} "
                f"held-out {h['fb_loss']:.1f}",
                flush=True,
            )
    except FbilError as exc:
        print(f"fb_heldout: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        out: dict[str, Any] = {"data": args.data, "heldout": args.heldout, "rows": rows}
        out["batches"], out["seed"] = args.batches, args.seed
        atomic_write_text(Path(args.json), json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
