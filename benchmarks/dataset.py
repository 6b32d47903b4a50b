"""Load time and sampling rate of a 1M-transition dataset in ExORL layout.

Writes 1000 episodes of 1000 steps (synthetic arrays of the domain's sizes, written by
fbil's own episode writer) to a temporary folder unless --dir names an existing dataset,
then times `load_dataset` and `Dataset.sample` (+ `sample_future`, what FB's z sampling
adds). The baseline is a plain per-episode loop that samples like ExORL's loader (pick an
episode, then a step, one transition at a time), measured in the same run.

    python benchmarks/dataset.py [--domain walker] [--episodes 1000] [--dir DIR] [--json]
"""

from __future__ import annotations

import argparse
import json
import random
import tempfile
import time
from pathlib import Path

import numpy as np

from fbil.data import load_dataset
from fbil.data.storage import list_episodes, load_episode, write_episode
from fbil.envs import get_domain


def make_synthetic(root: Path, domain: str, episodes: int, steps: int) -> None:
    spec = get_domain(domain)
    rng = np.random.default_rng(0)
    for i in range(episodes):
        write_episode(
            root,
            i,
            {
                "observation": rng.normal(size=(steps + 1, spec.obs_dim)).astype(np.float32),
                "action": rng.uniform(-1, 1, (steps + 1, spec.act_dim)).astype(np.float32),
                "reward": np.zeros((steps + 1, 1), np.float32),
                "discount": np.ones((steps + 1, 1), np.float32),
                "physics": rng.normal(size=(steps + 1, spec.physics_dim)),
            },
        )


def exorl_style_sampling(root: Path, batch: int, batches: int) -> tuple[float, float]:
    """Per-episode dicts, one Python-level sample per transition, as ExORL's loader."""
    t0 = time.perf_counter()
    episodes = [load_episode(f.path) for f in list_episodes(root)]
    load_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(batches):
        rows = []
        for _ in range(batch):
            ep = random.choice(episodes)
            idx = np.random.randint(0, len(ep["observation"]) - 1) + 1
            rows.append((ep["observation"][idx - 1], ep["action"][idx], ep["observation"][idx]))
        np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows])
    return load_s, batch * batches / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--domain", default="point_mass_maze")
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--batch", type=int, default=1024)
    parser.add_argument("--dir", default=None, help="existing dataset (skips writing)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.dir) if args.dir else Path(tmp)
        write_s = 0.0
        if not args.dir:
            t0 = time.perf_counter()
            make_synthetic(root, args.domain, args.episodes, args.steps)
            write_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        data = load_dataset(root, domain=args.domain)
        load_s = time.perf_counter() - t0
        rng = np.random.default_rng(0)
        n_batches = 200
        t0 = time.perf_counter()
        for _ in range(n_batches):
            data.sample(args.batch, rng)
        sample_rate = args.batch * n_batches / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(n_batches):
            b = data.sample(args.batch, rng)
            fut = data.sample_future(b.index, 0.98, rng)
            data.observation[fut]
        future_rate = args.batch * n_batches / (time.perf_counter() - t0)
        base_load, base_rate = exorl_style_sampling(root, args.batch, 10)
        mem_mb = (data.observation.nbytes + data.action.nbytes + data.discount.nbytes) / 2**20
    result = {
        "domain": args.domain,
        "transitions": data.num_transitions,
        "write_seconds": round(write_s, 2),
        "load_seconds": round(load_s, 2),
        "memory_mb": round(mem_mb, 1),
        "sample_transitions_per_s": round(sample_rate),
        "sample_with_future_per_s": round(future_rate),
        "baseline_load_seconds": round(base_load, 2),
        "baseline_transitions_per_s": round(base_rate),
    }
    if args.json:
        print(json.dumps(result))
        return
    print(f"{args.domain}: {data.num_transitions:,} transitions, batch {args.batch}")
    print(f"{'':<34}{'fbil':>14}{'per-episode loop':>20}{'ratio':>8}")
    print(f"{'load (s)':<34}{load_s:>14.2f}{base_load:>20.2f}{base_load / load_s:>7.2f}x")
    print(
        f"{'sampled transitions/s':<34}{sample_rate:>14,.0f}{base_rate:>20,.0f}"
        f"{sample_rate / base_rate:>7.0f}x"
    )
    print(f"{'  + future states (FB z sampling)':<34}{future_rate:>14,.0f}")
    print(f"memory of obs+action+discount: {mem_mb:.0f} MB (float32, contiguous)")


if __name__ == "__main__":
    main()
