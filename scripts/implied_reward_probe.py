"""Which half of the model bounds imitation by reward inference: the reward a z stands for,
or the policy that should maximise it? (`fbil.evaluation.implied` says what each column
measures.) For ERFB's z from each task's first committed demonstration, and for z_r:

- gap >= 0: pi_z collects at least as much of its own reward as the demonstration does,
  yet it does not do the task: the implied reward is what fails (a bound in B).
- gap < 0: the demonstration earns more of z's reward than pi_z does; then actor_gap near 0
  says the actor takes F's best actions (F's values are the bound), >= 1 that F knows
  better actions than the actor takes (the actor is the bound).

Write the JSON next to a domain's committed results as `implied_reward.json` and `fbil
report` adds the table to that domain's report.

Usage: python scripts/implied_reward_probe.py MODEL --data DIR --demos DIR [--tasks all]
           [--episodes 10] [--horizon 300] [--actions 64] [--plain] [--json FILE]
"""

from __future__ import annotations

import json

from probe_cli import load, probe_parser

from fbil.checkpoint import atomic_write_text
from fbil.evaluation.implied import ProbeSettings, probe_model

HEADER = (
    "z      task        return  r_z: rollout    demo    data (std)     gap"
    "  value: pred / collected  actor_gap demo / rollout  demo_adv  local demo / rollout"
)


def row_text(name: str, task: str, r: dict) -> str:
    """One printed line of the table."""
    v, d, o = r["value"], r["at_demo"], r["at_rollout"]
    return (
        f"{name:6} {task:10} {r['return_mean']:7.1f}  {r['r_z_rollout']:13.2f} "
        f"{r['r_z_demo']:7.2f} {r['r_z_data_mean']:7.2f} ({r['r_z_data_std']:5.2f}) "
        f"{r['gap']:7.2f}  {v['predicted']:8.1f} / {v['collected']:8.1f}"
        f"  {d['actor_gap']:6.2f} / {o['actor_gap']:6.2f}  {d.get('demo_adv', float('nan')):6.2f}"
        f"  {d['actor_gap_local']:6.2f} / {o['actor_gap_local']:6.2f}"
    )


def main() -> None:
    p = probe_parser(__doc__.splitlines()[0])
    p.add_argument("--horizon", type=int, default=300, help="steps of the value check")
    p.add_argument("--actions", type=int, default=64, help="random actions of the actor check")
    p.add_argument("--plain", action="store_true", help="r_z = B^T z, without C^-1")
    args = p.parse_args()
    model, data, tasks = load(args)
    cfg = ProbeSettings(args.episodes, args.horizon, args.actions, args.plain)
    table = {"model": args.model, **probe_model(model, data, args.demos, tasks, cfg)}
    print(HEADER)
    for task, row in table["tasks"].items():
        for name in ("ERFB", "z_r"):
            print(row_text(name, task, row[name]))
    if args.json:
        atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    main()
