"""TD3 gradient steps/s at the expert size: the bf16 path against plain fp32, same run.

Times `TD3.update` (critic step every call; actor step and targets every second call) on
random batches of the walker's sizes (obs 24, action 6; hidden 256, batch 256 as
`fbil expert`) with `precision=bf16` (hidden layers under bf16 autocast, last layers fp32)
and with fp32, in alternating slices of ~1 s; `speedup` is the ratio of wall-clock rates,
`cpu_speedup` that of CPU time per step (robust to other processes' load).

    python benchmarks/td3_update.py [--threads 1] [--seconds 20] [--hidden 256] [--json]
        [--arch mlp|two_stream] [--batch 256]

`--hidden` sets the networks' width (e.g. 1024, the paper's), to plan an expert's budget;
`--arch two_stream --batch 512` times GOAL-TD3's pre-training with the paper's networks
(inputs [s, g]: the goal is a second state).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

import torch
from fb_update import interleaved_rates

from fbil.agents.td3 import TD3, TD3Config
from fbil.envs import get_domain


def updater(
    domain: str, precision: str, hidden: int = 256, arch: str = "mlp", batch: int = 256
) -> tuple[TD3, Callable[[], None]]:
    spec = get_domain(domain)
    goal = arch == "two_stream"  # conditioned on a goal state: inputs [s, g]
    inp = 2 * spec.obs_dim if goal else spec.obs_dim
    cfg = TD3Config(
        hidden=hidden,
        batch_size=batch,
        nstep=3,
        precision=precision,  # type: ignore[arg-type]
        arch=arch,  # type: ignore[arg-type]
        cond_dim=spec.obs_dim if goal else 0,
    )
    agent = TD3(inp, spec.act_dim, cfg, seed=0)
    gen = torch.Generator().manual_seed(0)
    n = cfg.batch_size

    def step() -> None:
        obs = torch.randn(n, inp, generator=gen)
        act = torch.rand(n, spec.act_dim, generator=gen) * 2 - 1
        rew = torch.rand(n, generator=gen)
        nxt = torch.randn(n, inp, generator=gen)
        agent.update(obs, act, rew, nxt, torch.full((n,), 0.99**2))

    t0 = time.perf_counter()
    for _ in range(4):  # allocations, first calls
        step()
    agent.warmup_seconds = time.perf_counter() - t0  # type: ignore[attr-defined]
    return agent, step


def bf16_against_fp32(
    bf16_step: Callable[[], Any], fp32_step: Callable[[], Any], seconds: float
) -> dict[str, float]:
    """Rates of two update callables timed in alternating slices, and their ratios."""
    rates = interleaved_rates({"bf16": bf16_step, "fp32": fp32_step}, seconds)
    bf16, fp32 = rates["bf16"], rates["fp32"]
    return {
        "bf16_steps_per_s": round(bf16["steps_per_s"], 1),
        "fp32_steps_per_s": round(fp32["steps_per_s"], 1),
        "speedup": round(bf16["steps_per_s"] / fp32["steps_per_s"], 2),
        "bf16_cpu_ms_per_step": round(bf16["cpu_ms"], 2),
        "fp32_cpu_ms_per_step": round(fp32["cpu_ms"], 2),
        "cpu_speedup": round(fp32["cpu_ms"] / bf16["cpu_ms"], 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=1, help="1, as experts train")
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--domain", default="walker")
    parser.add_argument("--hidden", type=int, default=256, help="256, as `fbil expert`")
    parser.add_argument("--arch", choices=("mlp", "two_stream"), default="mlp")
    parser.add_argument("--batch", type=int, default=256, help="256, as `fbil expert`")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    sizes = (args.hidden, args.arch, args.batch)
    _, bf16_step = updater(args.domain, "bf16", *sizes)
    _, fp32_step = updater(args.domain, "fp32", *sizes)
    result = {
        "threads": torch.get_num_threads(),
        "domain": args.domain,
        "hidden": args.hidden,
        "arch": args.arch,
        "batch": args.batch,
        **bf16_against_fp32(bf16_step, fp32_step, args.seconds),
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"TD3 update ({args.domain}, {args.arch} {args.hidden}, batch {args.batch}, "
            f"{result['threads']} threads): bf16 "
            f"{result['bf16_steps_per_s']} steps/s, fp32 {result['fp32_steps_per_s']}, "
            f"speedup {result['speedup']}x (CPU time: {result['cpu_speedup']}x)"
        )


if __name__ == "__main__":
    main()
