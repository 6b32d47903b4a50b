#!/usr/bin/env bash
# The five walker experts (online TD3, n-step 3) and their demonstrations: 20
# standard-start and 10 shifted-start (App. E.5: from step 500 of an expert rollout) per task.
# Usage: scripts/walker_experts.sh [RUNS_DIR] [DEMOS_DIR] [THREADS]
# TASKS="a b" limits the tasks (e.g. to split them over two processes); STEPS_<task>=N
# sets a task's budget (env steps = gradient steps); PRECISION=bf16 trains TD3's hidden
# layers under bf16 autocast (docs/walker.md). Resumable: a finished expert is skipped,
# an interrupted one continues from its checkpoint.
set -euo pipefail
RUNS=${1:-runs/experts_online/walker}
DEMOS=${2:-artifacts/demos/walker}
THREADS=${3:-1}
PRECISION=${PRECISION:-fp32}
TASKS=${TASKS:-stand walk run flip spin}
mkdir -p "$RUNS" "$DEMOS"
for task in $TASKS; do
  out="$RUNS/$task"
  budget_var="STEPS_$task"
  steps=${!budget_var:-300000}
  if [ ! -f "$out/expert.json" ]; then
    resume=""
    [ -f "$out/checkpoint.safetensors" ] && resume="--resume"
    fbil expert walker "$task" --mode online --out "$out" --steps "$steps" --eval-every 20000 \
      --threads "$THREADS" --set nstep=3 --set precision="$PRECISION" $resume
  fi
  [ -f "$DEMOS/$task.npz" ] || fbil demos "$out" --episodes 20 --out "$DEMOS/$task.npz" --seed 0
  [ -f "$DEMOS/${task}_shifted.npz" ] || \
    fbil demos "$out" --episodes 10 --out "$DEMOS/${task}_shifted.npz" --starts shifted --seed 0
done
