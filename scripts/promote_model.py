"""Make the model that a seeds.json's rule chose the domain's committed default (issue #23).

The chosen folder's model, config and zero-shot returns (and the run's training log) are
copied into artifacts/models/DOMAIN with a manifest that says how the model was trained
(`--command`), which rule chose it among which seeds, and which model it replaced. The new
folder is built beside the old one and swapped in whole, so a failure leaves the old default
untouched. Pictures that belong to a model (value maps) are made afterwards, by their own
commands, and recorded with `scripts/refresh_manifest.py`.

Usage: python scripts/promote_model.py SEEDS.json --command "HOW THE MODEL WAS TRAINED"
           [--out artifacts/models/DOMAIN] [--train-log PATH] [--note KEY=TEXT ...]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import Any

from fbil.artifacts import COMMAND_PREFIXES, MANIFEST, sha256, write_manifest
from fbil.csvlog import last_wall_seconds
from fbil.errors import FbilError
from fbil.fb.train import git_commit

MODEL_FILES = ("model.safetensors", "config.json", "zero_shot.json")
LOG = "train_log.csv"


def _read_json(path: Path, what: str) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise FbilError(f"{path} does not exist; give the {what}") from None
    except (OSError, ValueError) as exc:
        raise FbilError(f"{path} is not readable JSON ({exc}); regenerate the {what}") from None
    if not isinstance(data, dict):
        raise FbilError(f"{path} is not a JSON object; regenerate the {what}")
    return data


def find_log(model: Path, given: str | None) -> Path:
    """The training log: `given`, else the model folder's, else that of the run above it (a
    snapshot `RUN/raw/snapshots/step_N` logs into `RUN/train_log.csv`)."""
    if given:
        path = Path(given)
        if not path.is_file():
            raise FbilError(f"--train-log {given}: no such file")
        return path
    for folder in (model, *model.parents[:3]):
        if (folder / LOG).is_file():
            return folder / LOG
    raise FbilError(f"no {LOG} in {model} or the three folders above it; pass --train-log")


def _previous(out: Path) -> dict[str, Any] | None:
    """What the default was before: its commit, model digest, zero-shot summary, command."""
    if not (out / MANIFEST).is_file():
        return None
    old = _read_json(out / MANIFEST, "old manifest")
    keep = ("git_commit", "command", "zero_shot_summary", "selection_rule", "steps", "seed")
    prev = {k: old[k] for k in keep if k in old}
    prev["model_sha256"] = old.get("sha256", {}).get("model.safetensors")
    return prev


def _zero_shot_summary(model: Path, tasks: list[str]) -> str:
    per_task = _read_json(model / "zero_shot.json", "zero-shot returns")["tasks"]
    chosen = tasks or sorted(per_task)
    values = [float(per_task[t]["return_mean"]) for t in chosen]
    mean = sum(values) / len(values)
    listed = " / ".join(f"{v:.1f}" for v in values)
    return f"mean {mean:.1f} over {', '.join(chosen)} ({listed})"


def manifest_extra(seeds_path: Path, seeds: dict[str, Any], model: Path, out: Path) -> dict:
    config = _read_json(model / "config.json", "model config")
    tasks = list(seeds.get("zero_shot_tasks") or [])
    members = [f"{e['model']} (seed {e.get('seed')})" for e in seeds["seeds"]]
    return {
        "steps": config.get("steps"),
        "train_config": config.get("train_config"),
        "dataset_history": config.get("dataset_history"),
        "zero_shot_summary": _zero_shot_summary(model, tasks),
        "selection_rule": (
            f"{seeds['rule']} over {len(members)} seeds of one recipe, fixed before their "
            f"results were seen; chose {seeds['chosen']} among: {'; '.join(members)}"
        ),
        "seeds_file": {"path": str(seeds_path), "sha256": sha256(seeds_path)},
        "previous_model": _previous(out),
    }


def promote(seeds_path: Path, command: str, out: Path | None, log: str | None, notes: dict):
    seeds = _read_json(seeds_path, "seeds file (scripts/model_seeds.py)")
    if not seeds.get("chosen") or not seeds.get("seeds"):
        raise FbilError(f"{seeds_path} names no chosen model; rerun scripts/model_seeds.py")
    model = Path(seeds["chosen"])
    missing = [f for f in MODEL_FILES if not (model / f).is_file()]
    if missing:
        raise FbilError(f"{model} lacks {', '.join(missing)}; train and check it first")
    from fbil.fb.model import FBModel

    trained_on = FBModel.load(model).domain  # names and shapes checked before any write
    if trained_on and trained_on != seeds["domain"]:
        raise FbilError(f"{model} was trained on {trained_on}, not {seeds['domain']}")
    if not command.startswith(COMMAND_PREFIXES):
        starts = ", ".join(repr(c.strip()) for c in COMMAND_PREFIXES)
        raise FbilError(
            f"--command must start with {starts} (a command to paste), got {command[:40]!r}"
        )
    out = out or Path("artifacts/models") / seeds["domain"]
    train_log = find_log(model, log)
    extra = manifest_extra(seeds_path, seeds, model, out) | notes
    stage = out.parent / f".{out.name}.new"
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir(parents=True)
    for name in MODEL_FILES:
        shutil.copy2(model / name, stage / name)
    shutil.copy2(train_log, stage / LOG)
    seed = next((e.get("seed") for e in seeds["seeds"] if e["model"] == seeds["chosen"]), None)
    write_manifest(stage, command, seed, last_wall_seconds(train_log) or None, git_commit(), extra)
    old = out.parent / f".{out.name}.old"
    shutil.rmtree(old, ignore_errors=True)
    if out.exists():
        out.rename(old)
    stage.rename(out)
    shutil.rmtree(old, ignore_errors=True)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("seeds", help="seeds.json of scripts/model_seeds.py")
    p.add_argument("--command", required=True, help="how the chosen model was trained")
    p.add_argument("--out", default=None, help="default: artifacts/models/DOMAIN")
    p.add_argument("--train-log", default=None, help="default: found beside the model")
    p.add_argument("--note", action="append", default=[], metavar="KEY=TEXT")
    args = p.parse_args(argv)
    try:
        notes = {}
        for item in args.note:
            key, sep, text = item.partition("=")
            if not sep or not key:
                raise FbilError(f"--note {item!r} is not KEY=TEXT")
            notes[key] = text
        out = promote(
            Path(args.seeds), args.command, args.out and Path(args.out), args.train_log, notes
        )
    except FbilError as exc:
        print(f"promote_model: error: {exc}", file=sys.stderr)
        return 2
    print(f"{out}: the default model now ({out / MANIFEST})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
