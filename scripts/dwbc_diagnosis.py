"""DWBC on one maze task, watched while it trains: the discriminator's mean output on the
demo and on dataset rows, the share of dataset rows it calls expert-like (d >= 0.5), the
policy weights, the policy's action error on the demo, then the returns of 10 episodes.

Variants: `dwbc` (the objective of `fbil.baselines.dwbc`) and `bc` (the same networks and
minibatches, weights 1 on expert rows and 0 on dataset rows: Gaussian BC on the demo).
The demo is draw 0 of K = 1, as `fbil benchmark` draws it. One thread.

Usage: python scripts/dwbc_diagnosis.py TASK {dwbc,bc} STEPS [--data DIR] [--demos DIR]
"""

from __future__ import annotations

import argparse
import json
import time

import torch

from fbil.baselines import dwbc
from fbil.baselines.bc import mean_action_policy
from fbil.baselines.common import demo_transitions, standardiser
from fbil.baselines.offline_td3 import MixedSampler
from fbil.data import load_dataset
from fbil.envs.rollout import rollout
from fbil.evaluation.evaluate import demo_draw
from fbil.imitation import Demos


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("task")
    p.add_argument("variant", choices=["dwbc", "bc"])
    p.add_argument("steps", type=int)
    p.add_argument("--data", default="datasets/point_mass_maze/rnd_uniform_1000_x4")
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    args = p.parse_args()
    torch.set_num_threads(1)
    data = load_dataset(args.data)
    demos = demo_draw(Demos.load(f"{args.demos}/{args.task}.npz"), 1, 0)
    expert = demo_transitions(demos)
    cfg = dwbc.DWBCConfig(steps=args.steps)
    torch.manual_seed(0)
    gen = torch.Generator().manual_seed(0)
    model = dwbc.DWBC(standardiser(data.observation, 1e-3), data.action.shape[1], cfg)
    sample = MixedSampler(data, expert, 2 * cfg.batch_size, 0.5, gen)
    weights = dwbc.policy_weights
    if args.variant == "bc":

        def bc_weights(
            d_e: torch.Tensor, d_o: torch.Tensor, alpha: float, eta: float
        ) -> tuple[torch.Tensor, torch.Tensor]:
            return torch.ones_like(d_e), torch.zeros_like(d_o)

        dwbc.policy_weights = bc_weights
    started = time.time()
    for i in range(1, args.steps + 1):
        batch = sample()
        data_rows = batch.select(~batch.expert)
        model.update(batch.select(batch.expert), data_rows)
        if i % max(1, args.steps // 5):
            continue
        with torch.no_grad():
            lp_e, lp_o = model.log_prob(expert), model.log_prob(data_rows)
            d_e = torch.sigmoid(model.logits(expert, lp_e))
            d_o = torch.sigmoid(model.logits(data_rows, lp_o))
            w_e, w_o = weights(d_e, d_o, cfg.alpha, cfg.eta)
            out = model.policy(model.norm(expert.obs))
            assert expert.action is not None
            error = (torch.tanh(out[:, : model.act_dim]) - expert.action).abs().mean()
        row = {
            "step": i,
            "d_expert": float(d_e.mean()),
            "d_data": float(d_o.mean()),
            "data_share_d_ge_half": float((d_o >= 0.5).float().mean()),
            "w_expert": float(w_e.mean()),
            "w_data": float(w_o.mean()),
            "demo_action_error": float(error),
            "seconds": time.time() - started,
        }
        print(json.dumps({k: round(v, 4) for k, v in row.items()}), flush=True)
    policy = mean_action_policy("dwbc", model.policy, model.stats, model.act_dim, {})
    returns = rollout("point_mass_maze", args.task, policy, list(range(10))).reward.sum(-1)
    summary = {"variant": args.variant, "task": args.task, "returns": returns.round(1).tolist()}
    print(json.dumps({**summary, "return_mean": round(float(returns.mean()), 1)}))


if __name__ == "__main__":
    main()
