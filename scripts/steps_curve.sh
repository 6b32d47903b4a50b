#!/usr/bin/env bash
set -euo pipefail
# Imitation score against FB training steps (issue #23): for each snapshot folder given,
# the model's zero-shot returns (kept where a zero_shot.json exists) and a reduced standard
# K = 1 grid of the paper's main eight methods into SNAP/steps_curve.jsonl, the same at every
# point. Resumable: the grid skips finished jobs; rerun the same command after a kill.
# `python scripts/steps_curve.py` then summarises the points (steps_curve.json).
#
# Usage: scripts/steps_curve.sh DATA SNAP...
#   env: ZS_EPISODES (50), DRAWS (2), EPISODES (10), THREADS (1)
cd "$(dirname "$0")/.."
DATA=${1:?usage: scripts/steps_curve.sh DATA SNAP...}
shift
[ "$#" -gt 0 ] || { echo "error: no snapshot folders given; usage: scripts/steps_curve.sh DATA SNAP..." >&2; exit 2; }
export MUJOCO_GL=${MUJOCO_GL:-egl}
THREADS=${THREADS:-1}
for snap in "$@"; do
  [ -f "$snap/model.safetensors" ] || { echo "error: $snap has no model.safetensors; give snapshot folders" >&2; exit 2; }
  domain=$(python -c 'import json, sys; print(json.load(open(sys.argv[1]))["dataset_manifest"]["domain"])' "$snap/config.json")
  if [ ! -f "$snap/zero_shot.json" ]; then
    echo "== $(date -u +%FT%TZ) zero-shot $snap"
    fbil zero-shot "$snap" --data "$DATA" --tasks all --episodes "${ZS_EPISODES:-50}" --threads "$THREADS" --json \
      > "$snap/zero_shot.json.part" && mv "$snap/zero_shot.json.part" "$snap/zero_shot.json"
  fi
  echo "== $(date -u +%FT%TZ) reduced K = 1 grid $snap"
  fbil benchmark --domain "$domain" --model "$snap" --demos "artifacts/demos/$domain" --methods all --k 1 \
    --draws "${DRAWS:-2}" --episodes "${EPISODES:-10}" --workers 1 --threads "$THREADS" --quiet \
    --out "$snap/steps_curve.jsonl"
done
echo "== $(date -u +%FT%TZ) done"
