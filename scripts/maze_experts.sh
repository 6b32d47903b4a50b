#!/usr/bin/env bash
# The eight maze experts (offline TD3 on the RND dataset relabeled per task) and their
# demonstrations: 20 standard-start and 10 shifted-start per task.
# Usage: scripts/maze_experts.sh [DATA_DIR] [RUNS_DIR] [DEMOS_DIR] [STEPS] [THREADS]
# TASKS="a b" limits the tasks (e.g. to split them over two processes); NSTEP=n sets
# TD3's n-step return (default 10; shorter or longer returns did not rescue the
# dense-reward tasks fast_slow and reach_bottom_left_long, online fine-tuning did: see
# docs/experts.md, "Other n-step returns offline").
# ONLINE_STEPS=N then fine-tunes each offline expert online for N env steps (`--init`, one
# update per step) into RUNS/<task>_online, and records the demos from that expert.
# Resumable: a finished expert is skipped, an interrupted one continues from its checkpoint.
set -euo pipefail
DATA=${1:-datasets/point_mass_maze/rnd_uniform}
RUNS=${2:-runs/experts/point_mass_maze}
DEMOS=${3:-artifacts/demos/point_mass_maze}
STEPS=${4:-30000}
THREADS=${5:-1}
NSTEP=${NSTEP:-10}
ONLINE_STEPS=${ONLINE_STEPS:-0}
TASKS=${TASKS:-reach_top_left reach_top_right reach_bottom_left reach_bottom_right reach_bottom_left_long loop square fast_slow}
mkdir -p "$RUNS" "$DEMOS"
for task in $TASKS; do
  out="$RUNS/$task"
  if [ ! -f "$out/expert.json" ]; then
    resume=""
    [ -f "$out/checkpoint.safetensors" ] && resume="--resume"
    fbil expert point_mass_maze "$task" --mode offline --data "$DATA" --out "$out" \
      --steps "$STEPS" --eval-every 5000 --threads "$THREADS" --set nstep="$NSTEP" $resume
  fi
  if [ "$ONLINE_STEPS" -gt 0 ]; then
    tuned="$RUNS/${task}_online"
    if [ ! -f "$tuned/expert.json" ]; then
      if [ -f "$tuned/checkpoint.safetensors" ]; then init="--resume"; else init="--init $out"; fi
      fbil expert point_mass_maze "$task" --mode online --out "$tuned" --steps "$ONLINE_STEPS" \
        --eval-every 5000 --start-steps 2000 --threads "$THREADS" --set nstep="$NSTEP" $init
    fi
    out="$tuned"
  fi
  [ -f "$DEMOS/$task.npz" ] || fbil demos "$out" --episodes 20 --out "$DEMOS/$task.npz" --seed 0
  [ -f "$DEMOS/${task}_shifted.npz" ] || \
    fbil demos "$out" --episodes 10 --out "$DEMOS/${task}_shifted.npz" --starts shifted --seed 0
done
