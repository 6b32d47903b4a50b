#!/usr/bin/env bash
set -euo pipefail
# A paired screen of one training setting on a finished maze FB run (issue #23): copy the
# run's checkpoint to OUT, resume it to STEPS with the extra settings, then check the
# result: zero-shot over all eight tasks (50 episodes) and the K = 1 grid of METHODS
# (5 draws x 20 episodes). Run it twice, with and without the setting, for the pair.
# Every step resumes after a kill: rerun the same command.
#
# Usage: scripts/maze_screen.sh FROM OUT SEED [--set k=v ...]
#   env: DATA (datasets/point_mass_maze/rnd_uniform_1000_x4), STEPS (440000),
#        METHODS (erfb,goalfb), THREADS (1)
cd "$(dirname "$0")/.."
FROM=${1:?usage: scripts/maze_screen.sh FROM OUT SEED [--set k=v ...]}
OUT=${2:?usage: scripts/maze_screen.sh FROM OUT SEED [--set k=v ...]}
SEED=${3:?usage: scripts/maze_screen.sh FROM OUT SEED [--set k=v ...]}
shift 3
DATA=${DATA:-datasets/point_mass_maze/rnd_uniform_1000_x4}
THREADS=${THREADS:-1}
export MUJOCO_GL=${MUJOCO_GL:-egl}
if [ ! -f "$OUT/checkpoint.safetensors" ]; then
  mkdir -p "$OUT"
  cp "$FROM/checkpoint.safetensors" "$FROM/config.json" "$FROM/train_log.csv" "$OUT/"
fi
echo "== $(date -u +%FT%TZ) train $OUT to ${STEPS:-440000} $*"
fbil pretrain point_mass_maze --data "$DATA" --preset cpu --out "$OUT" --steps "${STEPS:-440000}" \
  --seed "$SEED" --threads "$THREADS" --set snapshot_every=50000 "$@" --resume
if [ ! -f "$OUT/zero_shot.json" ]; then
  echo "== $(date -u +%FT%TZ) zero-shot $OUT"
  fbil zero-shot "$OUT" --data "$DATA" --tasks all --episodes 50 --threads "$THREADS" --json \
    > "$OUT/zero_shot.json.part" && mv "$OUT/zero_shot.json.part" "$OUT/zero_shot.json"
fi
echo "== $(date -u +%FT%TZ) K = 1 grid $OUT"
fbil benchmark --domain point_mass_maze --model "$OUT" --demos artifacts/demos/point_mass_maze \
  --methods "${METHODS:-erfb,goalfb}" --k 1 --draws 5 --episodes 20 --workers 1 \
  --threads "$THREADS" --quiet --out "$OUT/results.jsonl"
echo "== $(date -u +%FT%TZ) done $OUT"
