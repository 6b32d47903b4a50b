#!/usr/bin/env bash
set -euo pipefail
# Carry a training run to a later session (a fresh machine keeps only what is committed):
#   scripts/carry.sh save RUN NAME   copies RUN's checkpoint.safetensors, config.json and
#                                    train_log.csv (a GOAL-TD3 run: goal_checkpoint.safetensors
#                                    and goal_train_log.csv) to carry/NAME/ (commit it);
#   scripts/carry.sh load NAME RUN   puts them back in RUN, where `--resume` (or the script
#                                    that started the run) continues exactly.
# RUN may also be a benchmark's fit folder (`runs/baselines/.OUT.jsonl.fits`): its saved
# fits (`*.safetensors`, one per job in flight, each naming its job, settings and data) go
# and come back alike, and the same `fbil benchmark --out OUT.jsonl` resumes them.
# Replay buffers, snapshots and datasets are not carried: datasets are regenerated from
# their manifests' commands. Each committed checkpoint stays in git history (~10 MB at
# maze size): carry only runs that will be continued. CARRY_DIR (default: the repository's
# carry/) is where the named folders live.
cd "$(dirname "$0")/.."
root=${CARRY_DIR:-carry}
usage="usage: scripts/carry.sh save RUN NAME | load NAME RUN"
verb=${1:?$usage}
case "$verb" in
  save) src=${2:?$usage}; dst=$root/${3:?$usage} ;;
  load) src=$root/${2:?$usage}; dst=${3:?$usage} ;;
  *) echo "error: unknown verb '$verb'; $usage" >&2; exit 2 ;;
esac
# An FB run (`fbil pretrain`) or a GOAL-TD3 pre-training (`fbil pretrain-goal`, whose
# config is inside its checkpoint until it ends).
files="checkpoint.safetensors config.json train_log.csv"
[ -f "$src/goal_checkpoint.safetensors" ] && files="goal_checkpoint.safetensors goal_train_log.csv"
fits=""  # neither: a benchmark's fit folder, or its carried copy
if [ ! -f "$src/checkpoint.safetensors" ] && [ ! -f "$src/goal_checkpoint.safetensors" ]; then
  fits=$(cd "$src" 2>/dev/null && ls -- *.safetensors 2>/dev/null | tr '\n' ' ' || true)
  [ -z "$fits" ] || files=$fits
fi
for f in $files; do
  [ -f "$src/$f" ] || { echo "error: $src/$f is missing; is $src a training run's folder?" >&2; exit 2; }
done
mkdir -p "$dst"
for f in $files; do
  cp "$src/$f" "$dst/$f.part" && mv "$dst/$f.part" "$dst/$f"
done
if [ -n "$fits" ]; then
  echo "$verb: $src -> $dst ($(echo $fits | wc -w) saved fit(s): $fits)"
  exit 0
fi
log=$dst/${files##* }  # the training log is each set's last file
echo "$verb: $src -> $dst ($(tail -n 1 "$log" | cut -d, -f1) steps in its log)"
