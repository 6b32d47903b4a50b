#!/usr/bin/env bash
# A domain's experts (online TD3, n-step 3) and their demonstrations: 20 standard-start and
# 10 shifted-start (App. E.5: from step 500 of an expert rollout) per task.
# Usage: scripts/experts.sh DOMAIN [RUNS_DIR] [DEMOS_DIR] [THREADS]
#   RUNS_DIR defaults to runs/experts_online/DOMAIN, DEMOS_DIR to artifacts/demos/DOMAIN.
# Settings (environment):
#   TASKS="a b"      limits the tasks (default: every task of DOMAIN, from `fbil tasks`),
#                    e.g. to split them over two processes; start the slow ones first
#   STEPS_<task>=N   a task's budget (env steps = gradient steps; default 300000)
#   PRECISION=bf16   trains TD3's hidden layers under bf16 autocast (docs/walker.md)
#   DATA=DIR         the domain's unsupervised dataset, relabeled with the task, as half of
#                    each minibatch from the start (docs/walker.md, "What walker teaches",
#                    lesson 4); unset: the replay buffer only (walker's recorded experts)
#   DEMO_PHYSICS=first  keeps physics states for the first demo of each file only (the one
#                    pictures draw; `fbil demos --physics`); default all (exact relabeling)
#   DRY=1            prints the commands without running them
# Resumable: a finished expert is skipped, an interrupted one continues from its checkpoint.
set -euo pipefail
DOMAIN=${1:?usage: scripts/experts.sh DOMAIN [RUNS_DIR] [DEMOS_DIR] [THREADS]}
RUNS=${2:-runs/experts_online/$DOMAIN}
DEMOS=${3:-artifacts/demos/$DOMAIN}
THREADS=${4:-1}
PRECISION=${PRECISION:-fp32}
KNOWN=$(fbil tasks --json | python -c "import json, sys
print(' '.join(json.load(sys.stdin)['domains'].get(sys.argv[1], {}).get('tasks', [])))" "$DOMAIN")
if [ -z "$KNOWN" ]; then
  echo "error: unknown domain '$DOMAIN'; \`fbil tasks\` lists the domains" >&2
  exit 2
fi
TASKS=${TASKS:-$KNOWN}
for task in $TASKS; do
  case " $KNOWN " in *" $task "*) ;; *)
    echo "error: unknown $DOMAIN task '$task' in TASKS; known: $KNOWN" >&2
    exit 2 ;;
  esac
done
run() { echo "+ $*"; [ -n "${DRY:-}" ] || "$@"; }
[ -n "${DRY:-}" ] || mkdir -p "$RUNS" "$DEMOS"
for task in $TASKS; do
  out="$RUNS/$task"
  budget_var="STEPS_$task"
  steps=${!budget_var:-300000}
  if [ ! -f "$out/expert.json" ]; then
    extra=()
    [ -f "$out/checkpoint.safetensors" ] && extra+=(--resume)
    [ -n "${DATA:-}" ] && extra+=(--data "$DATA")
    run fbil expert "$DOMAIN" "$task" --mode online --out "$out" --steps "$steps" \
      --eval-every 20000 --threads "$THREADS" --set nstep=3 --set precision="$PRECISION" \
      ${extra[@]+"${extra[@]}"}
  fi
  physics=(--physics "${DEMO_PHYSICS:-all}")
  [ -f "$DEMOS/$task.npz" ] || run fbil demos "$out" --episodes 20 --out "$DEMOS/$task.npz" \
    --seed 0 "${physics[@]}"
  [ -f "$DEMOS/${task}_shifted.npz" ] || run fbil demos "$out" --episodes 10 \
    --out "$DEMOS/${task}_shifted.npz" --starts shifted --seed 0 "${physics[@]}"
done
