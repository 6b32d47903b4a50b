"""FB gradient steps/s on a CUDA device against the same machine's CPU, same run.

For the `cpu` and `paper` presets of the maze and walker, builds trainers on a synthetic
in-memory dataset (benchmarks/fb_update.py's) and times, in alternating slices of ~1 s:
the preset's own path on the GPU (`fbil pretrain --device cuda`: the preset's precision),
eager fp32 on the GPU, and the baseline, eager fp32 on this machine's CPU with all its
threads. Each GPU step ends with a device synchronisation, so the rates are completed
updates. `gpu_vs_cpu` is the ratio of the preset's GPU rate to the CPU baseline's;
`hours_per_100k` turns the GPU rate into the wall time of 100 000 updates (the walker
preset's length).

    python benchmarks/fb_update_cuda.py [--seconds 10] [--compile] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import torch

sys.path.insert(0, str(Path(__file__).parent))
from fb_update import interleaved_rates, trainer

from fbil.fb.train import FBTrainer

RUNS = {
    "cpu_maze": ("point_mass_maze", "cpu"),
    "cpu_walker": ("walker", "cpu"),
    "paper_maze": ("point_mass_maze", "paper"),
    "paper_walker": ("walker", "paper"),
}


def synced(tr: FBTrainer) -> Any:
    def step() -> None:
        tr.update()
        torch.cuda.synchronize()

    return step


def measure(domain: str, preset_name: str, seconds: float, compile: bool) -> dict[str, Any]:
    paths = {
        "gpu": trainer(domain, preset_name, "default", "cuda"),
        "gpu_fp32": trainer(domain, preset_name, "eager_fp32", "cuda"),
    }
    if compile:
        paths["gpu_compiled"] = trainer(domain, preset_name, "compiled", "cuda")
    steps: dict[str, Any] = {name: synced(tr) for name, tr in paths.items()}
    steps["cpu_fp32"] = trainer(domain, preset_name, "eager_fp32").update
    rates = {k: round(v["steps_per_s"], 2) for k, v in interleaved_rates(steps, seconds).items()}
    tr = paths["gpu"]
    out: dict[str, Any] = {f"{k}_steps_per_s": v for k, v in rates.items()}
    out["gpu_vs_cpu"] = round(rates["gpu"] / rates["cpu_fp32"], 1)
    out["hours_per_100k"] = round(1e5 / rates["gpu"] / 3600, 2)
    out.update(batch_size=tr.cfg.batch_size, f_hidden=tr.mcfg.f_hidden, precision=tr.cfg.precision)
    if compile:
        out["compile_seconds"] = round(paths["gpu_compiled"].warmup_seconds, 1)  # type: ignore[attr-defined]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="per configuration")
    parser.add_argument(
        "--configs", default=",".join(RUNS), help="a comma list of " + ", ".join(RUNS)
    )
    parser.add_argument("--compile", action="store_true", help="also torch.compile on the GPU")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if not torch.cuda.is_available():
        sys.exit("fb_update_cuda: error: no CUDA device here; run it on a GPU machine")
    configs = {}
    for name in args.configs.split(","):
        configs[name] = measure(*RUNS[name], args.seconds, args.compile)
        print(f"{name}: {json.dumps(configs[name])}", file=sys.stderr, flush=True)
    result = {
        "device": torch.cuda.get_device_name(),
        "cpu_threads": torch.get_num_threads(),
        "torch": torch.__version__,
        "configs": configs,
    }
    if args.json:
        print(json.dumps(result))
        return
    print(f"{result['device']} against {result['cpu_threads']} CPU threads")
    print(
        f"{'config':<14}{'GPU st/s':>10}{'GPU fp32':>10}{'CPU fp32':>10}{'GPU/CPU':>9}{'h/100k':>8}"
    )
    for name, r in configs.items():
        print(
            f"{name:<14}{r['gpu_steps_per_s']:>10.1f}{r['gpu_fp32_steps_per_s']:>10.1f}"
            f"{r['cpu_fp32_steps_per_s']:>10.1f}{r['gpu_vs_cpu']:>8.1f}x{r['hours_per_100k']:>8.2f}"
        )


if __name__ == "__main__":
    main()
