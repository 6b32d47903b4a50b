#!/usr/bin/env bash
set -euo pipefail
# One FB recipe run measured the way walker's recipe comparisons are (docs/walker.md):
#   train DOMAIN on DATA to STEPS updates (resuming OUT's checkpoint if there is one), then
#   zero-shot over all tasks, the standard K = 1 grid of the nine FB-IL methods, the z-drift
#   and actor check (scripts/z_drift.py --actor-check) and the implied-reward probe.
# Every step resumes after a kill: rerun the same command (training resumes from OUT's
# checkpoint; the grid skips finished jobs; finished measurements are kept).
#
# Usage: scripts/recipe_run.sh DOMAIN DATA OUT STEPS
#   env: SETS ("--set k=v ..." training settings), SEED (0), PRESET (cpu), THREADS (1),
#        ZS_EPISODES (20), DRAWS (5), EPISODES (20: per grid job), TASKS (all),
#        SNAPSHOT_EVERY (25000), WORKERS (1: grid workers, THREADS threads each)
cd "$(dirname "$0")/.."
usage="usage: scripts/recipe_run.sh DOMAIN DATA OUT STEPS"
DOMAIN=${1:?$usage}
DATA=${2:?$usage}
OUT=${3:?$usage}
STEPS=${4:?$usage}
THREADS=${THREADS:-1}
TASKS=${TASKS:-all}
read -r -a extra <<< "${SETS:-}"
export MUJOCO_GL=${MUJOCO_GL:-egl}
demos=artifacts/demos/$DOMAIN
[ -d "$demos" ] || { echo "error: no committed demos in $demos for $DOMAIN" >&2; exit 2; }

resume=()
[ -f "$OUT/checkpoint.safetensors" ] && resume=(--resume)
echo "== $(date -u +%FT%TZ) train $DOMAIN to $STEPS on $DATA"
fbil pretrain "$DOMAIN" --data "$DATA" --preset "${PRESET:-cpu}" --out "$OUT" --steps "$STEPS" \
  --seed "${SEED:-0}" --threads "$THREADS" --set "snapshot_every=${SNAPSHOT_EVERY:-25000}" \
  "${extra[@]}" "${resume[@]}"
if [ ! -f "$OUT/zero_shot.json" ]; then
  echo "== $(date -u +%FT%TZ) zero-shot"
  fbil zero-shot "$OUT" --data "$DATA" --tasks "$TASKS" --episodes "${ZS_EPISODES:-20}" \
    --threads "$THREADS" --json > "$OUT/zero_shot.json.part"
  mv "$OUT/zero_shot.json.part" "$OUT/zero_shot.json"
fi
echo "== $(date -u +%FT%TZ) standard K = 1 grid"
task_arg=()
[ "$TASKS" != all ] && task_arg=(--tasks "$TASKS")
fbil benchmark --domain "$DOMAIN" --model "$OUT" --demos "$demos" --methods fb-il --k 1 \
  --draws "${DRAWS:-5}" --episodes "${EPISODES:-20}" --workers "${WORKERS:-1}" --threads "$THREADS" --quiet \
  "${task_arg[@]}" --out "$OUT/results.jsonl"
if [ ! -f "$OUT/z_drift.json" ]; then
  echo "== $(date -u +%FT%TZ) z drift and actor check"
  OMP_NUM_THREADS=$THREADS python scripts/z_drift.py "$OUT" --demos "$demos" --tasks "$TASKS" \
    --draws "${DRAWS:-5}" --actor-check --json "$OUT/z_drift.json"
fi
if [ ! -f "$OUT/implied_reward.json" ]; then
  echo "== $(date -u +%FT%TZ) implied-reward probe"
  probe_tasks=()
  [ "$TASKS" != all ] && probe_tasks=(--tasks "$TASKS")
  OMP_NUM_THREADS=$THREADS python scripts/implied_reward_probe.py "$OUT" --data "$DATA" \
    --demos "$demos" --episodes 10 "${probe_tasks[@]}" --json "$OUT/implied_reward.json"
fi
echo "== $(date -u +%FT%TZ) done: python scripts/compare_models.py --run NAME=$OUT/results.jsonl,$OUT/zero_shot.json ..."
