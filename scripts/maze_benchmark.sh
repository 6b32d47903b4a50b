#!/usr/bin/env bash
set -euo pipefail
# The three maze grids of the report (standard K=1, shifted K=1, K=10) and the report.
# Resumable: each results file skips finished jobs; delete them to re-run with a new model.
cd "$(dirname "$0")/.."
R=artifacts/results/point_mass_maze
M=artifacts/models/point_mass_maze
D=artifacts/demos/point_mass_maze
start=$(date +%s)
fbil benchmark --domain point_mass_maze --model $M --demos $D --methods all --episodes 20 --workers 2 --k 1 --draws 5 --out $R/results.jsonl
fbil benchmark --domain point_mass_maze --model $M --demos $D --methods all --episodes 20 --workers 2 --k 1 --draws 5 --demo-set shifted --out $R/results_shifted.jsonl
fbil benchmark --domain point_mass_maze --model $M --demos $D --methods all --episodes 20 --workers 2 --k 10 --draws 2 --out $R/results_k10.jsonl
fbil report $R/results.jsonl $R/results_shifted.jsonl $R/results_k10.jsonl --out $R
echo "grids done in $(( $(date +%s) - start )) s"
