"""FB gradient steps/s: the default path against the plain eager fp32 update, same run.

For the `cpu` maze and walker sizes, builds trainers on a synthetic in-memory dataset: the
default path (`fbil pretrain`'s: the preset's precision, bf16 autocast), the baseline
(eager fp32) and, with `--compile`, the default path with its losses compiled by
torch.compile. They are timed in alternating slices of ~1 s, so that load from other
processes hits all alike, by wall clock and by this process's CPU time (which other
processes on the machine barely disturb); `speedup` is the ratio of wall-clock rates,
`cpu_speedup` that of CPU time per step. Also counts the update's floating-point
operations (FlopCounterMode) and reports the achieved GFLOP/s as a share of the bf16 and
fp32 matmul peaks measured in the same run.

    python benchmarks/fb_update.py [--threads 2] [--seconds 20] [--json] [--compile] [--profile]

`--profile` adds, per path, the CPU time per update spent in matrix products (aten's mm,
addmm, bmm and their oneDNN kernels, as torch.profiler's self time) and in everything
else, and `fusion_needed`: the factor by which the default path's non-matmul time would
have to fall for `cpu_speedup` to reach 2.5 with its matmuls as they are (no factor can
when the matmuls alone exceed the budget).
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


def interleaved_rates(
    steps: dict[str, Any], seconds: float, slice_s: float = 1.0
) -> dict[str, dict[str, float]]:
    """Steps per wall second and CPU ms per step of each callable, timed in alternating
    slices of `slice_s` seconds."""
    done = dict.fromkeys(steps, 0)
    wall = dict.fromkeys(steps, 0.0)
    cpu = dict.fromkeys(steps, 0.0)
    end = time.perf_counter() + seconds
    while time.perf_counter() < end or min(done.values()) < 3:
        for name, step in steps.items():
            t0, c0 = time.perf_counter(), time.process_time()
            while time.perf_counter() - t0 < slice_s or done[name] == 0:
                step()
                done[name] += 1
            wall[name] += time.perf_counter() - t0
            cpu[name] += time.process_time() - c0
    return {
        name: {"steps_per_s": done[name] / wall[name], "cpu_ms": 1e3 * cpu[name] / done[name]}
        for name in steps
    }


def trainer(domain: str, preset_name: str, path: str, device: str = "cpu") -> FBTrainer:
    """path: default (the preset as `fbil pretrain` runs it), compiled, or eager_fp32."""
    model_cfg, train_cfg = preset(domain, preset_name)
    if path == "eager_fp32":
        train_cfg = dataclasses.replace(train_cfg, precision="fp32")
    data = synthetic(domain)
    tr = FBTrainer(model_cfg, train_cfg, data, device=device, compile=path == "compiled")
    t0 = time.perf_counter()
    for _ in range(3):  # compilation, allocations, first-call overheads
        tr.update()
    if device.startswith("cuda"):
        torch.cuda.synchronize()
    tr.warmup_seconds = time.perf_counter() - t0  # type: ignore[attr-defined]
    return tr


MATMUL_OPS = ("aten::mm", "aten::addmm", "aten::bmm", "aten::_addmm_activation")


def matmul_split(tr: FBTrainer, steps: int = 20) -> dict[str, float]:
    """CPU ms per update in matrix products and in the rest (profiler self times)."""
    from torch.profiler import ProfilerActivity, profile

    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for _ in range(steps):
            tr.update()
    events = prof.key_averages()
    total = sum(e.self_cpu_time_total for e in events) / 1e3 / steps
    mm = sum(e.self_cpu_time_total for e in events if e.key in MATMUL_OPS) / 1e3 / steps
    # oneDNN's bf16 products appear as aten::mm calling mkldnn kernels: count those too.
    mm += sum(e.self_cpu_time_total for e in events if "mkldnn" in e.key) / 1e3 / steps
    return {"matmul_ms": round(mm, 2), "other_ms": round(total - mm, 2)}


def gflop_per_step(tr: FBTrainer) -> float:
    with FlopCounterMode(display=False) as counter:
        tr.update()
    return counter.get_total_flops() / 1e9


def measure(
    domain: str,
    preset_name: str,
    seconds: float,
    peaks: dict[str, float],
    compile: bool,
    profile: bool = False,
) -> dict[str, Any]:
    paths = ["default", "eager_fp32"] + (["compiled"] if compile else [])
    trainers = {path: trainer(domain, preset_name, path) for path in paths}
    flops = gflop_per_step(trainers["eager_fp32"])  # the same arithmetic on every path
    rates = interleaved_rates({p: t.update for p, t in trainers.items()}, seconds)
    base, default = rates["eager_fp32"], rates["default"]
    out: dict[str, Any] = {
        "default_steps_per_s": round(default["steps_per_s"], 2),
        "eager_fp32_steps_per_s": round(base["steps_per_s"], 2),
        "speedup": round(default["steps_per_s"] / base["steps_per_s"], 2),
        "default_cpu_ms_per_step": round(default["cpu_ms"], 2),
        "eager_fp32_cpu_ms_per_step": round(base["cpu_ms"], 2),
        "cpu_speedup": round(base["cpu_ms"] / default["cpu_ms"], 2),
        "gflop_per_step": round(flops, 3),
        "default_gflops": round(default["steps_per_s"] * flops, 1),
        "share_of_bf16_peak": round(default["steps_per_s"] * flops / peaks["bf16"], 3),
        "eager_fp32_share_of_fp32_peak": round(base["steps_per_s"] * flops / peaks["fp32"], 3),
        "batch_size": trainers["default"].cfg.batch_size,
        "z_dim": trainers["default"].mcfg.z_dim,
        "f_hidden": trainers["default"].mcfg.f_hidden,
        "default_precision": trainers["default"].cfg.precision,
    }
    if compile:
        comp = rates["compiled"]
        out["compiled_steps_per_s"] = round(comp["steps_per_s"], 2)
        out["compiled_cpu_ms_per_step"] = round(comp["cpu_ms"], 2)
        out["compile_seconds"] = round(trainers["compiled"].warmup_seconds, 1)  # type: ignore[attr-defined]
    if profile:
        split = {p: matmul_split(trainers[p]) for p in ("default", "eager_fp32")}
        out["profile"] = split
        fp32_total = split["eager_fp32"]["matmul_ms"] + split["eager_fp32"]["other_ms"]
        budget = fp32_total / 2.5 - split["default"]["matmul_ms"]
        out["fusion_needed"] = (
            round(split["default"]["other_ms"] / budget, 2) if budget > 0 else None
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--seconds", type=float, default=20.0, help="per configuration")
    parser.add_argument("--paper", action="store_true", help="also the paper-size configs")
    parser.add_argument("--compile", action="store_true", help="also the compiled path")
    parser.add_argument("--profile", action="store_true", help="matmul / other CPU time")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    peaks = {"fp32": matmul_peak(3.0), "bf16": matmul_peak(3.0, torch.bfloat16)}
    runs = [("cpu_maze", "point_mass_maze", "cpu"), ("cpu_walker", "walker", "cpu")]
    if args.paper:
        runs += [("paper_maze", "point_mass_maze", "paper"), ("paper_walker", "walker", "paper")]
    configs = {
        name: measure(dom, pre, args.seconds, peaks, args.compile, args.profile)
        for name, dom, pre in runs
    }
    result = {
        "threads": torch.get_num_threads(),
        "torch": torch.__version__,
        "peak_gflops_fp32": round(peaks["fp32"], 1),
        "peak_gflops_bf16": round(peaks["bf16"], 1),
        "configs": configs,
    }
    if args.json:
        print(json.dumps(result))
        return
    print(
        f"matmul peak: fp32 {peaks['fp32']:.1f}, bf16 {peaks['bf16']:.1f} GFLOP/s "
        f"({result['threads']} threads)"
    )
    print(
        f"{'config':<14}{'default st/s':>13}{'eager fp32':>11}{'speedup':>9}{'CPU speedup':>12}"
        f"{'GFLOP/step':>12}{'GFLOP/s':>9}{'% bf16 peak':>13}"
    )
    for name, r in configs.items():
        print(
            f"{name:<14}{r['default_steps_per_s']:>13.2f}{r['eager_fp32_steps_per_s']:>11.2f}"
            f"{r['speedup']:>8.2f}x{r['cpu_speedup']:>11.2f}x{r['gflop_per_step']:>12.3f}"
            f"{r['default_gflops']:>9.1f}{100 * r['share_of_bf16_peak']:>12.0f}%"
        )


if __name__ == "__main__":
    main()
