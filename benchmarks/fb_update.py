"""FB gradient steps/s at the `cpu` and `paper` sizes, next to the machine's matmul peak.

For maze and walker dimensions, times `FBTrainer.update()` (FB loss, orthonormality,
actor, targets) on a synthetic in-memory dataset, counts its floating-point operations
with PyTorch's FlopCounterMode, and reports the achieved GFLOP/s as a share of the fp32
matmul peak measured in the same run (a large square matmul; the bf16 peak too, since the
`cpu` preset runs its networks under bf16 autocast). `cpu_maze_fp32` is the same update
in fp32, the baseline for the ratio.

    python benchmarks/fb_update.py [--threads 2] [--seconds 10] [--json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.flop_counter import FlopCounterMode

from fbil.data.dataset import Dataset
from fbil.envs import get_domain
from fbil.fb.config import preset
from fbil.fb.train import FBTrainer


def matmul_peak(seconds: float, dtype: torch.dtype = torch.float32) -> float:
    n = 2048
    a, b = torch.randn(n, n, dtype=dtype), torch.randn(n, n, dtype=dtype)
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


def measure(
    domain: str, preset_name: str, seconds: float, precision: str | None = None
) -> dict[str, Any]:
    model_cfg, train_cfg = preset(domain, preset_name)
    if precision is not None:
        train_cfg = dataclasses.replace(train_cfg, precision=precision)
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
        "precision": train_cfg.precision,
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
    peak_bf16 = matmul_peak(3.0, torch.bfloat16)
    configs = {}
    for name, domain, preset_name, precision in (
        ("cpu_maze", "point_mass_maze", "cpu", None),
        ("cpu_maze_fp32", "point_mass_maze", "cpu", "fp32"),
        ("cpu_walker", "walker", "cpu", None),
        ("paper_maze", "point_mass_maze", "paper", None),
        ("paper_walker", "walker", "paper", None),
    ):
        budget = args.seconds if preset_name == "cpu" else args.seconds / 2
        configs[name] = measure(domain, preset_name, budget, precision)
    result = {
        "threads": torch.get_num_threads(),
        "peak_gflops": round(peak, 1),
        "peak_gflops_bf16": round(peak_bf16, 1),
        "configs": configs,
    }
    if args.json:
        print(json.dumps(result))
        return
    print(
        f"matmul peak: fp32 {peak:.1f}, bf16 {peak_bf16:.1f} GFLOP/s "
        f"({torch.get_num_threads()} threads)"
    )
    print(
        f"{'config':<15}{'precision':>10}{'batch':>7}{'d':>5}{'hidden':>8}{'steps/s':>10}"
        f"{'GFLOP/step':>12}{'GFLOP/s':>9}{'% fp32 peak':>13}"
    )
    for name, r in configs.items():
        print(
            f"{name:<15}{r['precision']:>10}{r['batch_size']:>7}{r['z_dim']:>5}"
            f"{r['f_hidden']:>8}{r['steps_per_s']:>10.2f}{r['gflop_per_step']:>12.3f}"
            f"{r['gflops']:>9.1f}{100 * r['gflops'] / peak:>12.0f}%"
        )


if __name__ == "__main__":
    main()
