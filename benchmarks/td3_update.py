"""TD3 gradient steps/s at the expert size: the default (compiled) path against eager.

Times `TD3.update` (critic step every call; actor step and targets every second call) on
random batches of the walker's sizes (obs 24, action 6; hidden 256, batch 256 as
`fbil expert`), with the losses compiled by torch.compile (what `fbil expert` does for runs
of >= 5 000 steps) and eagerly, in alternating slices of ~1 s in the same run; `speedup`
is their ratio. Both paths run fp32.

    python benchmarks/td3_update.py [--threads 1] [--seconds 20] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import torch
from fb_update import interleaved_rates

from fbil.agents.td3 import TD3, TD3Config
from fbil.envs import get_domain


def updater(domain: str, fast: bool) -> tuple[TD3, object]:
    spec, cfg = get_domain(domain), TD3Config(nstep=3)
    agent = TD3(spec.obs_dim, spec.act_dim, cfg, seed=0, compile=fast)
    gen = torch.Generator().manual_seed(0)
    n = cfg.batch_size

    def step() -> None:
        obs = torch.randn(n, spec.obs_dim, generator=gen)
        act = torch.rand(n, spec.act_dim, generator=gen) * 2 - 1
        rew = torch.rand(n, generator=gen)
        nxt = torch.randn(n, spec.obs_dim, generator=gen)
        agent.update(obs, act, rew, nxt, torch.full((n,), 0.99**2))

    t0 = time.perf_counter()
    for _ in range(4):  # compilation of both losses
        step()
    agent.warmup_seconds = time.perf_counter() - t0  # type: ignore[attr-defined]
    return agent, step


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=1, help="1, as experts train")
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--domain", default="walker")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    fast, fast_step = updater(args.domain, True)
    _, eager_step = updater(args.domain, False)
    rates = interleaved_rates({"default": fast_step, "eager": eager_step}, args.seconds)
    result = {
        "threads": torch.get_num_threads(),
        "domain": args.domain,
        "default_steps_per_s": round(rates["default"], 1),
        "eager_steps_per_s": round(rates["eager"], 1),
        "speedup": round(rates["default"] / rates["eager"], 2),
        "compile_seconds": round(fast.warmup_seconds, 1),  # type: ignore[attr-defined]
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"TD3 update ({args.domain}, {result['threads']} threads): default "
            f"{result['default_steps_per_s']} steps/s, eager {result['eager_steps_per_s']}, "
            f"speedup {result['speedup']}x (compile {result['compile_seconds']} s)"
        )


if __name__ == "__main__":
    main()
