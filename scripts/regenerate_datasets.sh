#!/usr/bin/env bash
set -euo pipefail
# Regenerate a domain's unsupervised datasets on a fresh machine, exactly as recorded in
# artifacts/datasets/DOMAIN/manifest.json (the committed models, experts and baselines were
# trained on these), then check them against the committed dataset-info.
#   scripts/regenerate_datasets.sh point_mass_maze   ~45 min of one core: rnd_uniform (408
#       episodes), rnd_uniform_1000 (--resume to 1 000), rnd_uniform_1000_x4 (doorway
#       oversampling), random_uniform_200 and the two merges of issue #23's mixed recipe,
#       each checked against its committed dataset-info
#   scripts/regenerate_datasets.sh walker            ~40-45 min: datasets/walker/rnd (1 M)
#   scripts/regenerate_datasets.sh cheetah           ~25 min: datasets/cheetah/rnd (1 M)
# Skips a dataset whose folder is complete. THREADS (1) per job; DRY=1 prints the commands.
# A dataset that does not match its committed dataset-info is reported and the script goes
# on to the next one, then exits 1. On another kind of CPU than the one that made the
# committed data (another vendor or vector width) RND collection drifts and never matches:
# the data are then a new sample of the same recipe, not a copy (docs/datasets.md).
cd "$(dirname "$0")/.."
DOMAIN=${1:?usage: scripts/regenerate_datasets.sh point_mass_maze|walker|cheetah}
THREADS=${THREADS:-1}
export MUJOCO_GL=${MUJOCO_GL:-egl}
run() { echo "+ $*"; [ -n "${DRY:-}" ] || "$@"; }
have() { [ -f "$1/manifest.json" ] && [ -z "${DRY:-}" ]; }
check() {  # check NAME DATASET COMMITTED_INFO: dataset-info must match the committed one
  [ -n "${DRY:-}" ] && return 0
  fbil dataset-info "$2" --json > "/tmp/regen_info_$1.json"
  python - "/tmp/regen_info_$1.json" "$3" <<'PY'
import json, sys
def flat(d, p=""):
    out = {}
    for k, v in d.items():
        out.update(flat(v, p + k + ".") if isinstance(v, dict) else {p + k: v})
    return out
new, old = (flat(json.load(open(f))) for f in sys.argv[1:])
diff = sorted(k for k in set(new) | set(old)
              if new.get(k) != old.get(k) and k != "plot" and not k.endswith("seconds"))
print(f"{sys.argv[1]}: " + ("matches " + sys.argv[2] if not diff else f"DIFFERS in {diff}"))
sys.exit(1 if diff else 0)
PY
}
FAILED=()
case "$DOMAIN" in
  point_mass_maze)
    D=datasets/point_mass_maze
    A=artifacts/datasets/point_mass_maze
    have $D/rnd_uniform_1000 || {
      have $D/rnd_uniform || run fbil collect point_mass_maze --explorer rnd --episodes 408 \
        --starts uniform --out $D/rnd_uniform --seed 0 --threads "$THREADS"
      run rm -rf $D/rnd_uniform_1000
      run cp -r $D/rnd_uniform $D/rnd_uniform_1000
      run rm -rf $D/rnd_uniform_1000/cache
      run fbil collect point_mass_maze --explorer rnd --episodes 1000 --starts uniform \
        --out $D/rnd_uniform_1000 --seed 0 --threads "$THREADS" --resume
    }
    have $D/rnd_uniform_1000_x4 || run fbil dataset-oversample $D/rnd_uniform_1000 --out $D/rnd_uniform_1000_x4
    check x4 $D/rnd_uniform_1000_x4 $A/info_rnd_uniform_1000_x4.json || FAILED+=(rnd_uniform_1000_x4)
    have $D/random_uniform_200 || run fbil collect point_mass_maze --explorer random --episodes 200 \
      --starts uniform --out $D/random_uniform_200 --seed 1 --threads "$THREADS"
    have $D/rnd1000_random200 || run fbil dataset-merge $D/rnd_uniform_1000 $D/random_uniform_200 --out $D/rnd1000_random200
    have $D/rnd_x4_random200 || run fbil dataset-merge $D/rnd_uniform_1000_x4 $D/random_uniform_200 --out $D/rnd_x4_random200
    for n in random_uniform_200 rnd1000_random200 rnd_x4_random200; do
      check "$n" "$D/$n" "$A/info_$n.json" || FAILED+=("$n")
    done
    ;;
  walker|cheetah)  # locomotion: one RND collection of 1 000 episodes, walker's recipe
    D=datasets/$DOMAIN/rnd
    have "$D" || run fbil collect "$DOMAIN" --explorer rnd --episodes 1000 \
      --out "$D" --seed 0 --threads "$THREADS"
    check "$DOMAIN" "$D" "artifacts/datasets/$DOMAIN/info.json" || FAILED+=("$DOMAIN/rnd")
    ;;
  *) echo "error: no regeneration recipe for domain '$DOMAIN'; known: point_mass_maze, walker, cheetah" >&2; exit 2 ;;
esac
if [ ${#FAILED[@]} -gt 0 ]; then
  cpu=$(python -c "from fbil.artifacts import machine; print(machine())")
  echo "error: ${FAILED[*]} regenerated but differ from the committed dataset-info on this CPU" \
    "($cpu); a CPU of another kind than the committed data's gives a new sample of the same" \
    "recipe, not a copy: compare results only within one dataset (results lines' data_digest)" >&2
  exit 1
fi
