"""scripts/promote_model.py: the seed a seeds.json chose becomes the committed default, with
a manifest that verifies, names the rule and the model it replaced; bad input changes
nothing and gets one line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from fbil.artifacts import verify
from fbil.fb.config import preset
from fbil.fb.model import FBModel
from tests.script_module import SCRIPTS

TASKS = ["reach_top_left", "reach_top_right"]


def _seed_model(root: Path, name: str, seed: int, reach: float, domain: str) -> Path:
    torch.manual_seed(seed)
    folder = root / name / "raw" / "snapshots" / "step_0000100"
    meta = {"dataset_manifest": {"domain": domain}, "steps": 100}
    FBModel(preset(domain, "smoke")[0], metadata=meta).save(folder)
    body = json.loads((folder / "config.json").read_text())
    body["train_config"] = {"seed": seed}
    (folder / "config.json").write_text(json.dumps(body))
    tasks = {t: {"return_mean": reach + i, "return_std": 1.0} for i, t in enumerate(TASKS)}
    (folder / "zero_shot.json").write_text(json.dumps({"tasks": tasks}))
    log = "step,fb_loss,wall_seconds\n50,1.0,10.5\n100,0.5,21.25\n"
    (root / name / "train_log.csv").write_text(log)  # the run's log, above the snapshot
    return folder


def _seeds(root: Path, chosen: Path, models: list[Path], domain: str) -> Path:
    """A seeds.json (named after the chosen run) that chose `chosen` among `models`."""
    entries = [{"model": str(m), "seed": i, "domain": domain} for i, m in enumerate(models)]
    body = {"domain": domain, "rule": "median_zero_shot", "zero_shot_tasks": TASKS,
            "chosen": str(chosen), "seeds": entries}  # fmt: skip
    path = root / f"seeds_{chosen.parents[2].name}.json"
    path.write_text(json.dumps(body))
    return path


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, str(SCRIPTS / "promote_model.py"), *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


@pytest.fixture
def runs(tmp_path: Path) -> list[Path]:
    return [
        _seed_model(tmp_path, f"s{i}", i, r, "point_mass_maze")
        for i, r in enumerate((500.0, 600.0, 700.0))
    ]


def test_the_chosen_seed_replaces_the_default_with_a_manifest(
    runs: list[Path], tmp_path: Path
) -> None:
    out = tmp_path / "artifacts" / "models" / "point_mass_maze"
    out.mkdir(parents=True)
    (out / "model.safetensors").write_bytes(b"old weights")
    old = {"git_commit": "abc1234", "command": "old recipe", "sha256": {"model.safetensors": "f0"}}
    (out / "manifest.json").write_text(json.dumps(old))
    seeds = _seeds(tmp_path, runs[1], runs, "point_mass_maze")
    res = _run(seeds, "--command", "fbil pretrain it so", "--out", out, "--note", "why=a test")
    assert res.returncode == 0, res.stderr
    verify(out)  # every file's sha256 as recorded
    assert sorted(p.name for p in out.iterdir()) == [
        "config.json", "manifest.json", "model.safetensors", "train_log.csv", "zero_shot.json"
    ]  # fmt: skip
    assert (out / "model.safetensors").read_bytes() == (runs[1] / "model.safetensors").read_bytes()
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["command"] == "fbil pretrain it so" and manifest["seed"] == 1
    assert manifest["wall_seconds"] == 21.25  # the run's log, found above the snapshot
    assert manifest["previous_model"]["git_commit"] == "abc1234"
    assert manifest["previous_model"]["model_sha256"] == "f0"
    assert "median_zero_shot over 3 seeds" in manifest["selection_rule"]
    assert manifest["zero_shot_summary"].startswith("mean 600.5 over reach_top_left")
    assert manifest["why"] == "a test"
    assert not list(out.parent.glob(".point_mass_maze.*"))  # no staging folder left behind


def test_bad_input_leaves_the_default_untouched(runs: list[Path], tmp_path: Path) -> None:
    out = tmp_path / "default"
    out.mkdir()
    (out / "model.safetensors").write_bytes(b"old weights")
    walker = _seed_model(tmp_path, "w", 3, 400.0, "walker")
    corrupt = _seed_model(tmp_path, "c", 4, 400.0, "point_mass_maze")
    (corrupt / "model.safetensors").write_bytes(b"not safetensors")
    (tmp_path / "broken.json").write_text("{")
    cases = [
        (tmp_path / "broken.json", "not readable JSON"),
        (tmp_path / "none.json", "does not exist"),
        (_seeds(tmp_path, walker, [*runs, walker], "point_mass_maze"), "trained on walker"),
        (_seeds(tmp_path, corrupt, [*runs, corrupt], "point_mass_maze"), "corrupt weights"),
    ]
    for seeds, message in cases:
        res = _run(seeds, "--command", "fbil pretrain x", "--out", out)
        assert res.returncode == 2 and message in res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1
    res = _run(
        _seeds(tmp_path, runs[1], runs, "point_mass_maze"), "--command", "SETS=1 x", "--out", out
    )
    assert res.returncode == 2 and "--command must start with" in res.stderr, res.stderr
    assert (out / "model.safetensors").read_bytes() == b"old weights"
    assert sorted(p.name for p in out.iterdir()) == ["model.safetensors"]
