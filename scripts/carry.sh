#!/usr/bin/env bash
set -euo pipefail
# Carry a training run to a later session (a fresh machine keeps only what is committed):
#   scripts/carry.sh save RUN NAME   copies RUN's checkpoint.safetensors, config.json and
#                                    train_log.csv to carry/NAME/ (commit that folder);
#   scripts/carry.sh load NAME RUN   puts them back in RUN, where `--resume` (or the script
#                                    that started the run) continues exactly.
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
for f in checkpoint.safetensors config.json train_log.csv; do
  [ -f "$src/$f" ] || { echo "error: $src/$f is missing; is $src a training run's folder?" >&2; exit 2; }
done
mkdir -p "$dst"
for f in checkpoint.safetensors config.json train_log.csv; do
  cp "$src/$f" "$dst/$f.part" && mv "$dst/$f.part" "$dst/$f"
done
echo "$verb: $src -> $dst ($(tail -n 1 "$dst/train_log.csv" | cut -d, -f1) steps in its log)"
