"""FB gradient steps/s at the `cpu` and `paper` sizes, next to the machine's matmul peak.

For maze and walker dimensions, times `FBTrainer.update()` (FB loss, orthonormality,
actor, targets) on a synthetic in-memory dataset, counts its floating-point operations
with PyTorch's FlopCounterMode, and reports the achieved GFLOP/s as a share of the fp32
matmul peak measured in the same run (a large square matmul).

    python benchmarks/fb_update.py [--threads 2] [--seconds 10] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch
from torch.utils.flop_counter import FlopCounterMode

from fbil.data.dataset import Dataset
from fbil.envs import get_domain
from fbil.fb.config import preset
from fbil.fb.train import FBTrainer


def matmul_peak(seconds: float) -> float:
    n = 2048
    a, b = torch.randn(n, n), torch.randn(n, n)
    best, end = 0.0, time.perf_counter() + seconds
    while time.perf_counter() < end:
        t0 = time.perf_counter()
        a @ b
        best = max(best, 2 * n**3 / (time.perf_counter() - t0) / 1e9)
    return best


def synthetic(domain: str, episodes: int = 20, steps: int = 1000) -> Dataset:
    spec = get_domain(domain)
    rng = np.random.default_rng(0)
    n = episodes * (steps + 1)
    return Dataset(
        Path("/nonexistent"),
        domain,
        [],
        rng.normal(size=(n, spec.obs_dim)).astype(np.float32),
        rng.uniform(-1, 1, (n, spec.act_dim)).astype(np.float32),
        np.ones(n, np.float32),
        np.arange(episodes) * (steps + 1),
    )


def measure(domain: str, preset_name: str, seconds: float) -> dict[str, float]:
    model_cfg, train_cfg = preset(domain, preset_name)
    trainer = FBTrainer(model_cfg, train_cfg, synthetic(domain))
    trainer.update()  # warm-up (allocations, first-call overheads)
    with FlopCounterMode(display=False) as counter:
        trainer.update()
    flops = counter.get_total_flops()
    done, t0 = 0, time.perf_counter()
    while done < 3 or time.perf_counter() - t0 < seconds:
        trainer.update()
        done += 1
    rate = done / (time.perf_counter() - t0)
    return {
        "steps_per_s": round(rate, 2),
        "gflop_per_step": round(flops / 1e9, 3),
        "gflops": round(rate * flops / 1e9, 1),
        "batch_size": train_cfg.batch_size,
        "z_dim": model_cfg.z_dim,
        "f_hidden": model_cfg.f_hidden,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--seconds", type=float, default=10.0, help="per configuration")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    peak = matmul_peak(3.0)
    configs = {}
    for name, domain, preset_name in (
        ("cpu_maze", "point_mass_maze", "cpu"),
        ("cpu_walker", "walker", "cpu"),
        ("paper_maze", "point_mass_maze", "paper"),
        ("paper_walker", "walker", "paper"),
    ):
        budget = args.seconds if preset_name == "cpu" else args.seconds / 2
        configs[name] = measure(domain, preset_name, budget)
    result = {"threads": torch.get_num_threads(), "peak_gflops": round(peak, 1), "configs": configs}
    if args.json:
        print(json.dumps(result))
        return
    print(f"fp32 matmul peak: {peak:.1f} GFLOP/s ({torch.get_num_threads()} threads)")
    print(
        f"{'config':<14}{'batch':>7}{'d':>5}{'hidden':>8}{'steps/s':>10}{'GFLOP/step':>12}"
        f"{'GFLOP/s':>9}{'% peak':>8}"
    )
    for name, r in configs.items():
        print(
            f"{name:<14}{r['batch_size']:>7}{r['z_dim']:>5}{r['f_hidden']:>8}"
            f"{r['steps_per_s']:>10.2f}{r['gflop_per_step']:>12.3f}{r['gflops']:>9.1f}"
            f"{100 * r['gflops'] / peak:>7.0f}%"
        )


if __name__ == "__main__":
    main()
