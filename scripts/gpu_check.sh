#!/usr/bin/env bash
# The checks that need a CUDA device, in one pass (docs/speed.md, "On a GPU"):
#   1. tests/fb/test_cuda.py (skipped everywhere else);
#   2. benchmarks/fb_update_cuda.py: updates/s on the GPU against this machine's CPU;
#   3. `fbil pretrain --device cuda` for the maze's cpu and paper presets on a real dataset,
#      timed, then the zero-shot of the cpu-preset run on two reach tasks (MuJoCo, CPU).
# Usage: scripts/gpu_check.sh OUT_DIR MAZE_DATA [STEPS]   (each step has its own timeout;
# the models go to a temporary folder, OUT_DIR gets seven small files)
set -u
out=$1; data=$2; steps=${3:-5000}
work=$(mktemp -d); mkdir -p "$out"; export PYTHONUNBUFFERED=1 MUJOCO_GL=${MUJOCO_GL:-egl}
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv | tee "$out/gpu.txt"
timeout 120 python3 -m pytest -q -p no:cacheprovider tests/fb/test_cuda.py 2>&1 | tee "$out/pytest.txt"
timeout 150 python3 benchmarks/fb_update_cuda.py --seconds 6 --json > "$out/fb_update_cuda.json"
cat "$out/fb_update_cuda.json"
for p in cpu paper; do
  t0=$(date +%s)
  timeout 75 python3 -m fbil pretrain point_mass_maze --data "$data" --preset $p --device cuda \
    --steps "$steps" --out "$work/maze_$p" --threads 4 2>&1 | tail -3
  echo "pretrain $p $steps steps: $(( $(date +%s) - t0 )) s (with start-up)" | tee -a "$out/pretrain.txt"
  cp "$work/maze_$p/train_log.csv" "$out/train_log_$p.csv"
done
timeout 60 python3 -m fbil zero-shot "$work/maze_cpu" --data "$data" \
  --tasks reach_top_left,reach_bottom_right --episodes 2 --json | tee "$out/zero_shot.json"
