"""Gradient steps/s of the offline-IL baselines' RL learners at their `cpu` budget sizes:
the default path (bf16 autocast on the hidden layers) against plain fp32, same run.

Times one update of the offline TD3 of td3il / oril / otr (`OfflineTD3Config`, batch 512,
256 units), of the SAC of sqil / iq-learn (`SACConfig`) and one step of the discriminator
of oril and the DICE methods (`DiscriminatorConfig`: BCE on 512 expert and 512 dataset rows
plus the gradient penalty, on (s, a)) and one joint nu and policy step of the DICE methods
(`DualConfig`, KL) on random batches of a domain's sizes, in alternating slices of ~1 s;
`cpu_speedup` is the ratio of CPU time per update (robust to other processes' load),
`speedup` that of wall-clock rates.

    python benchmarks/baseline_update.py [--domain point_mass_maze] [--seconds 10] [--json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from td3_update import bf16_against_fp32

from fbil.agents.td3 import TD3
from fbil.baselines.common import Transitions
from fbil.baselines.dice import DiceLearner, DualConfig
from fbil.baselines.offline_td3 import OfflineTD3Config
from fbil.baselines.oril import Discriminator, DiscriminatorConfig, discriminator_loss
from fbil.baselines.sac import SAC, SACConfig
from fbil.envs import get_domain


@dataclasses.dataclass
class _Data:
    """The two fields of a dataset that SAC reads at construction."""

    domain: str
    observation: np.ndarray
    action: np.ndarray


def _fake_data(domain: str) -> _Data:
    """1 000 random states and actions of the domain's sizes."""
    spec, rng = get_domain(domain), np.random.default_rng(0)
    return _Data(
        domain,
        rng.standard_normal((1000, spec.obs_dim)).astype(np.float32),
        rng.uniform(-1, 1, (1000, spec.act_dim)).astype(np.float32),
    )


def _batch(obs: int, act: int, n: int, gen: torch.Generator) -> Transitions:
    return Transitions(
        torch.randn(n, obs, generator=gen),
        torch.rand(n, act, generator=gen) * 2 - 1,
        torch.randn(n, obs, generator=gen),
        torch.ones(n),
        torch.zeros(n, dtype=torch.bool),
    )


def td3_step(domain: str, precision: str) -> Callable[[], Any]:
    spec = get_domain(domain)
    cfg = dataclasses.replace(OfflineTD3Config(), precision=precision).td3(domain)  # type: ignore[arg-type]
    agent = TD3(spec.obs_dim, spec.act_dim, cfg, seed=0)
    gen = torch.Generator().manual_seed(0)

    def step() -> None:
        b = _batch(spec.obs_dim, spec.act_dim, cfg.batch_size, gen)
        assert b.action is not None
        agent.update(
            b.obs, b.action, torch.rand(cfg.batch_size, generator=gen), b.next_obs, b.discount
        )

    return step


def sac_step(domain: str, precision: str) -> Callable[[], Any]:
    spec = get_domain(domain)
    cfg = SACConfig(precision=precision)  # type: ignore[arg-type]
    data = _fake_data(domain)
    agent = SAC(data, cfg, seed=0)
    gen = torch.Generator().manual_seed(0)

    def step() -> None:
        b = _batch(spec.obs_dim, spec.act_dim, cfg.batch_size, gen)
        agent.update(b, torch.rand(cfg.batch_size, generator=gen))

    return step


def discriminator_step(domain: str, precision: str) -> Callable[[], Any]:
    spec = get_domain(domain)
    cfg = DiscriminatorConfig(precision=precision)  # type: ignore[arg-type]
    stats = torch.stack([torch.zeros(spec.obs_dim), torch.ones(spec.obs_dim)])
    disc = Discriminator("sa", stats, spec.act_dim, cfg.hidden, cfg.precision)
    opt = torch.optim.Adam(disc.net.parameters(), lr=cfg.lr)
    gen = torch.Generator().manual_seed(0)

    def step() -> None:
        expert = disc.features(_batch(spec.obs_dim, spec.act_dim, cfg.batch_size, gen))
        data = disc.features(_batch(spec.obs_dim, spec.act_dim, cfg.batch_size, gen))
        loss = discriminator_loss(disc, expert, data, 10.0, gen)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    return step


def dice_step(domain: str, precision: str) -> Callable[[], Any]:
    spec = get_domain(domain)
    cfg = DualConfig(precision=precision)  # type: ignore[arg-type]
    data = _fake_data(domain)
    stats = torch.stack([torch.zeros(spec.obs_dim), torch.ones(spec.obs_dim)])
    learner = DiceLearner(Discriminator("sa", stats, spec.act_dim, 256, "bf16"), data, cfg)
    gen = torch.Generator().manual_seed(0)

    def step() -> None:
        b = _batch(spec.obs_dim, spec.act_dim, cfg.batch_size, gen)
        learner.update(b, torch.randn(cfg.batch_size, spec.obs_dim, generator=gen))

    return step


LEARNERS = (
    ("offline_td3", td3_step),
    ("sac", sac_step),
    ("discriminator", discriminator_step),
    ("dice", dice_step),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=1, help="1, as benchmark workers train")
    parser.add_argument("--seconds", type=float, default=10.0, help="per learner")
    parser.add_argument("--domain", default="point_mass_maze")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    result: dict[str, Any] = {"threads": torch.get_num_threads(), "domain": args.domain}
    for name, make in LEARNERS:
        steps = {p: make(args.domain, p) for p in ("bf16", "fp32")}
        for step in steps.values():
            for _ in range(3):  # allocations, first calls
                step()
        result[name] = bf16_against_fp32(steps["bf16"], steps["fp32"], args.seconds)
    if args.json:
        print(json.dumps(result))
        return
    for name, _ in LEARNERS:
        r = result[name]
        print(
            f"{name} ({args.domain}, {result['threads']} thread(s)): bf16 "
            f"{r['bf16_steps_per_s']} updates/s ({r['bf16_cpu_ms_per_step']} ms CPU), fp32 "
            f"{r['fp32_steps_per_s']} ({r['fp32_cpu_ms_per_step']} ms CPU): "
            f"{r['cpu_speedup']}x by CPU time, {r['speedup']}x by wall clock"
        )


if __name__ == "__main__":
    main()
