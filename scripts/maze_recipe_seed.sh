#!/usr/bin/env bash
set -euo pipefail
# One seed of a two-stage maze FB recipe, trained, checked and imitated (issue #23):
#   stage 1: STAGE1_STEPS on DATA1; stage 2: on to STEPS on DATA2 (the committed recipe is
#   200 000 on rnd_uniform_1000, then 400 000 on rnd_uniform_1000_x4);
#   then zero-shot over all eight tasks (50 episodes, over DATA2) and the standard K = 1 grid
#   of the eight FB-IL methods (5 draws x 20 episodes), the inputs of scripts/model_seeds.py.
# With SETS="--set ema_decay=D" the run also keeps a Polyak average (saved as OUT's model);
# the trained weights are the same to the bit, saved at OUT/raw/snapshots/step_<STEPS>, and
# both are checked: the trained weights first (the recipe's model, as without the average),
# then the average (OUT), each with its zero_shot.json and results.jsonl in its own folder.
# Every step resumes after a kill: rerun the same command (training resumes from OUT's
# checkpoint, written every 3 minutes; the grid skips finished jobs). To carry a run to a
# later session, commit OUT/checkpoint.safetensors, config.json and train_log.csv.
#
# Usage: scripts/maze_recipe_seed.sh OUT SEED [DATA1 DATA2]
#   env: STAGE1_STEPS (200000), STEPS (400000), THREADS (1), ZS_EPISODES (50), DRAWS (5),
#        EPISODES (20: per grid job),
#        SETS ("--set k=v ..." extra training settings, the same for both stages)
cd "$(dirname "$0")/.."
OUT=${1:?usage: scripts/maze_recipe_seed.sh OUT SEED [DATA1 DATA2]}
SEED=${2:?usage: scripts/maze_recipe_seed.sh OUT SEED [DATA1 DATA2]}
DATA1=${3:-datasets/point_mass_maze/rnd_uniform_1000}
DATA2=${4:-datasets/point_mass_maze/rnd_uniform_1000_x4}
STAGE1_STEPS=${STAGE1_STEPS:-200000}
STEPS=${STEPS:-400000}
THREADS=${THREADS:-1}
read -r -a extra <<< "${SETS:-}"
export MUJOCO_GL=${MUJOCO_GL:-egl}

done_steps() {  # the step of OUT's checkpoint (what --resume continues from), 0 before the first
  [ -f "$OUT/checkpoint.safetensors" ] || { echo 0; return; }
  python -c 'import json, sys; from safetensors import safe_open
with safe_open(sys.argv[1], "pt") as f:
    print(dict(json.loads(f.metadata()["fbil_state"])["__dict__"])["step"])' "$OUT/checkpoint.safetensors"
}
train() {  # train DATA N: resume (or start) the run on DATA up to step N
  local resume=()
  [ -f "$OUT/checkpoint.safetensors" ] && resume=(--resume)
  echo "== $(date -u +%FT%TZ) train to $2 on $1 (seed $SEED)"
  fbil pretrain point_mass_maze --data "$1" --preset cpu --out "$OUT" --steps "$2" --seed "$SEED" \
    --threads "$THREADS" --set snapshot_every=50000 "${extra[@]}" "${resume[@]}"
}
mkdir -p "$OUT"
[ "$(done_steps)" -lt "$STAGE1_STEPS" ] && train "$DATA1" "$STAGE1_STEPS"
[ "$(done_steps)" -lt "$STEPS" ] && train "$DATA2" "$STEPS"
check() {  # check MODEL: zero-shot and the K = 1 grid, into MODEL's folder
  if [ ! -f "$1/zero_shot.json" ]; then
    echo "== $(date -u +%FT%TZ) zero-shot $1"
    fbil zero-shot "$1" --data "$DATA2" --tasks all --episodes "${ZS_EPISODES:-50}" --threads "$THREADS" --json \
      > "$1/zero_shot.json.part" && mv "$1/zero_shot.json.part" "$1/zero_shot.json"
  fi
  echo "== $(date -u +%FT%TZ) standard K = 1 grid $1"
  fbil benchmark --domain point_mass_maze --model "$1" \
    --demos artifacts/demos/point_mass_maze --methods all --k 1 --draws "${DRAWS:-5}" --episodes "${EPISODES:-20}" \
    --workers 1 --threads "$THREADS" --quiet --out "$1/results.jsonl"
}
RAW=$OUT/raw/snapshots/step_$(printf %07d "$STEPS")
models=("$OUT")
[ -d "$OUT/raw" ] && models=("$RAW" "$OUT")  # ema_decay on: trained weights, then the average
for m in "${models[@]}"; do check "$m"; done
echo "== $(date -u +%FT%TZ) done: python scripts/model_seeds.py --run ${models[0]}=${models[0]}/results.jsonl ..."
