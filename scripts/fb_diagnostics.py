"""Cheap health checks of a trained FB model on its dataset, with no rollout (seconds).

  Cov B           eigenvalues of E[B B^T] over the data's next states (orthonormal: all 1)
  reward R^2      share of each task's reward variance that B(s')^T Cov^-1 z_r explains:
                  what z_r can express at all, whatever F and the actor learned
  measure mass    E_s[F(s, pi_z(s), z)]^T E[B]: the total mass of the learned successor
                  measure M(s, a, .) = sum_t gamma^t P(s_{t+1} in .), which is 1/(1 - gamma)
                  for the true measure; F^T E[B] sees the part of the constant function that
                  lies in span B, so the reference is E[B]^T Cov^-1 E[B] / (1 - gamma). A mass
                  far below it, or negative, says the FB target is biased (e.g. by the min
                  over two heads). Uninformative when E[B] ~ 0 (batch-normalised B).
                  Its spread over 8 random actions of a state (0 for the true measure) is
                  an action preference F holds whatever the reward.
  head gap        mean |F1^T z - F2^T z| at the policy's actions: the noise the min over
                  heads turns into a downward bias at every backup
  actor vs random share of states where mu(s, z) scores at least the best of 8 uniform
                  actions under the model's own Q = F^T z; and the share of saturated action
                  components (|a| > 0.95)
  Q(z_r)          mean F(s, pi(s), z_r)^T z_r per task: a non-negative reward gives Q >= 0
  cos(z, E[B])    where z_r points, against the training z's: the 99th percentile of
                  cos(z, E[B]) over training draws, and cos(z_r, E[B]) per task. A z_r far
                  beyond the training z's is a z the actor and F have never been trained on
                  (a reward's mean loads z_r onto E[B] when constants lie in span B)

z is drawn as in training (half Gaussian on the sphere, half B of a data state); the
diagnostics use --states random next states of the dataset (default 40 000, ~5 s).

Usage: python scripts/fb_diagnostics.py MODEL --data DIR [--states 40000] [--json]
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
import torch

from fbil.data import load_dataset
from fbil.envs import get_domain
from fbil.fb.model import FBModel


@torch.no_grad()
def diagnostics(model: FBModel, data: Any, states: int = 40_000, seed: int = 0) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed)
    n_all = len(data.next_index)
    idx = rng.choice(n_all, min(states, n_all), replace=False)
    nxt = data.next_index[idx]
    b = model.backward(data.observation[nxt]).double()
    cov = b.T @ b / len(b)
    e_b = b.mean(0)
    const_share = float(e_b @ torch.linalg.solve(cov, e_b))
    gamma = model.gamma
    out: dict[str, Any] = {
        "states": len(idx),
        "cov_b_eig_min": float(torch.linalg.eigvalsh(cov).min()),
        "cov_b_eig_max": float(torch.linalg.eigvalsh(cov).max()),
        "constant_share": const_share,
        "unbiased_mass": const_share / (1 - gamma),
    }
    # Policy-side checks on a subset of the states s (the transitions' first states).
    m = min(4_000, len(idx))
    s = torch.from_numpy(data.observation[nxt[:m] - 1])
    use_b = torch.rand(m, generator=gen) < 0.5
    perm = torch.randperm(len(b), generator=gen)[:m]
    z = model.project_z(
        torch.where(use_b[:, None], b[perm].float(), torch.randn(m, model.z_dim, generator=gen))
    )
    a = model.act(s, z)
    cos_train = torch.nn.functional.cosine_similarity(z.double(), e_b[None], dim=-1)
    out["train_z_cos_e_b_p99"] = float(torch.quantile(cos_train, 0.99))
    f_both = model.forward(s, z, a, heads="both").double()  # (2, m, d)
    out["measure_mass"] = float((f_both.mean(0) @ e_b).mean())
    q_heads = (f_both * z.double()).sum(-1)
    out["head_gap"] = float((q_heads[0] - q_heads[1]).abs().mean())
    q_pi = q_heads.mean(0)
    f_rand = [
        model.forward(s, z, torch.rand(m, a.shape[1], generator=gen) * 2 - 1, heads="both")
        .double().mean(0)
        for _ in range(8)
    ]  # fmt: skip
    q_rand = torch.stack([(f * z.double()).sum(-1) for f in f_rand])
    # the measure's mass at 8 random actions of each state: its spread over actions is an
    # action preference F holds whatever the reward (0 for the true measure)
    out["measure_mass_action_std"] = float(torch.stack([f @ e_b for f in f_rand]).std(0).mean())
    out["actor_beats_best_of_8_random"] = float((q_pi >= q_rand.max(0).values).double().mean())
    out["saturated_actions"] = float((a.abs() > 0.95).double().mean())
    tasks: dict[str, Any] = {}
    for task in get_domain(data.domain).task_names:
        r = torch.from_numpy(data.reward(task)[idx]).double()
        z_r = (r[:, None] * b).mean(0)
        r_hat = b @ torch.linalg.solve(cov, z_r)
        r2 = 1 - float(((r - r_hat) ** 2).mean() / r.var()) if r.var() > 0 else float("nan")
        zz = model.project_z(z_r.float()).expand(m, -1)
        q = (model.forward(s, zz, model.act(s, zz), heads="both").mean(0) * zz).sum(-1)
        cos = float(torch.nn.functional.cosine_similarity(z_r, e_b, dim=0))
        tasks[task] = {"reward_r2": r2, "q_z_r": float(q.mean()), "cos_z_r_e_b": cos}
    out["tasks"] = tasks
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True)
    p.add_argument("--states", type=int, default=40_000)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    res = diagnostics(FBModel.load(args.model), load_dataset(args.data), args.states)
    if args.json:
        print(json.dumps(res))
        return
    print(
        f"Cov B eigenvalues {res['cov_b_eig_min']:.2f}-{res['cov_b_eig_max']:.2f}; "
        f"measure mass {res['measure_mass']:.1f} "
        f"(unbiased fixed point {res['unbiased_mass']:.1f}; spread over actions "
        f"{res['measure_mass_action_std']:.1f}); "
        f"head gap {res['head_gap']:.2f}; actor >= best of 8 random actions in "
        f"{100 * res['actor_beats_best_of_8_random']:.0f} % of states; saturated action "
        f"components {100 * res['saturated_actions']:.0f} %"
    )
    print(f"training z: 99th percentile of cos(z, E[B]) {res['train_z_cos_e_b_p99']:.2f}")
    print(f"{'task':<24}{'reward R^2':>11}{'Q(z_r)':>10}{'cos(z_r, E[B])':>16}")
    for task, r in res["tasks"].items():
        print(f"{task:<24}{r['reward_r2']:>11.3f}{r['q_z_r']:>10.1f}{r['cos_z_r_e_b']:>16.2f}")


if __name__ == "__main__":
    main()
