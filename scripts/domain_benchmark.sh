#!/usr/bin/env bash
set -euo pipefail
# A domain's three FB-IL grids (standard K=1, shifted K=1, K=10) and its report, from the
# committed model and demos: artifacts/{models,demos,results}/DOMAIN.
# Usage: scripts/domain_benchmark.sh DOMAIN [METHODS] [WORKERS]
#   METHODS: fb-il (the nine FB-IL methods, default) or all (the paper's main eight).
# Resumable: each results file skips finished jobs; delete them to re-run with a new model.
# A baselines.jsonl beside the results (fbil benchmark --methods bc,... ) joins the report.
cd "$(dirname "$0")/.."
DOMAIN=${1:?usage: scripts/domain_benchmark.sh DOMAIN [METHODS] [WORKERS]}
METHODS=${2:-fb-il}
WORKERS=${3:-2}
R=artifacts/results/$DOMAIN
M=artifacts/models/$DOMAIN
D=artifacts/demos/$DOMAIN
mkdir -p "$R"
start=$(date +%s)
common=(--domain "$DOMAIN" --model "$M" --demos "$D" --methods "$METHODS" --episodes 20 --workers "$WORKERS" --quiet)
fbil benchmark "${common[@]}" --k 1 --draws 5 --out "$R/results.jsonl"
fbil benchmark "${common[@]}" --k 1 --draws 5 --demo-set shifted --out "$R/results_shifted.jsonl"
fbil benchmark "${common[@]}" --k 10 --draws 2 --out "$R/results_k10.jsonl"
files=("$R/results.jsonl" "$R/results_shifted.jsonl" "$R/results_k10.jsonl")
[ -f "$R/baselines.jsonl" ] && files+=("$R/baselines.jsonl")
fbil report "${files[@]}" --out "$R"
echo "grids done in $(( $(date +%s) - start )) s"
