#!/usr/bin/env bash
# Walker's five experts and their demos, as recorded in artifacts/demos/walker/manifest.json:
# scripts/experts.sh for walker (its settings TASKS, STEPS_<task>, PRECISION, DATA, DRY).
# Usage: scripts/walker_experts.sh [RUNS_DIR] [DEMOS_DIR] [THREADS]
exec "$(dirname "$0")/experts.sh" walker "$@"
