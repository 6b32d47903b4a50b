"""scripts/experts_table.py: a domain's experts.json and demos manifest from its experts'
folders, for any domain (the command and the data each expert trained on are recorded)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fbil.evaluation.paper import PAPER_RETURNS
from fbil.imitation import from_arrays
from tests.script_module import load_script

experts_table = load_script("experts_table")


def _expert(folder: Path, command: str, wall: float) -> None:
    folder.mkdir(parents=True)
    meta = {"mode": "online", "steps": 1000, "command": command, "best_step": 800}
    (folder / "expert.json").write_text(json.dumps(meta))
    (folder / "train_log.csv").write_text(f"step,return,wall\n1000,1.0,{wall}\n")


def _demos(path: Path, source: str, returns: list[float]) -> None:
    obs = [np.zeros((4, 17), np.float32) for _ in returns]
    meta = {"domain": "cheetah", "source": source, "return_mean": float(np.mean(returns)),
            "return_std": float(np.std(returns))}  # fmt: skip
    from_arrays(obs, [np.zeros((3, 6), np.float32) for _ in returns], meta).save(path)


def test_a_cheetah_table_records_returns_ratios_command_and_data(tmp_path: Path) -> None:
    demos, experts = tmp_path / "demos" / "cheetah", tmp_path / "experts"
    demos.mkdir(parents=True)
    _expert(
        experts / "walk", "fbil expert cheetah walk --mode online --data datasets/cheetah/rnd", 60.0
    )
    _demos(demos / "walk.npz", "TD3 expert walk", [790.0, 810.0])
    _demos(demos / "walk_shifted.npz", "TD3 expert walk", [900.0])
    experts_table.main(str(demos), str(experts))
    table = json.loads((demos / "experts.json").read_text())["tasks"]
    assert list(table) == ["walk"]  # tasks without a demo file are left out
    walk = table["walk"]
    assert walk["return_mean"] == 800.0 and walk["episodes"] == 2
    assert walk["ratio_to_paper"] == round(800.0 / PAPER_RETURNS["cheetah"]["expert"]["walk"], 3)
    assert walk["shifted_return_mean"] == 900.0 and walk["actor_step"] == 800
    manifest = json.loads((demos / "manifest.json").read_text())
    assert manifest["command"].startswith(f"scripts/experts.sh cheetah {experts} {demos} 1 ")
    assert manifest["data"] == "datasets/cheetah/rnd"
    assert manifest["wall_seconds"] == 60.0


def test_experts_without_prior_data_are_recorded_as_online_only(tmp_path: Path) -> None:
    demos, experts = tmp_path / "walker", tmp_path / "experts"
    demos.mkdir()
    _expert(experts / "stand", "fbil expert walker stand --mode online", 10.0)
    _demos(demos / "stand.npz", "TD3 expert stand", [950.0])
    experts_table.main(str(demos), str(experts))
    assert json.loads((demos / "manifest.json").read_text())["data"].startswith("none")


@pytest.mark.parametrize("demos_name", ["demos", "walkr"])
def test_a_folder_not_named_after_a_domain_is_refused(
    tmp_path: Path, demos_name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / demos_name).mkdir()
    with pytest.raises(SystemExit) as exit_:
        experts_table.main(str(tmp_path / demos_name), str(tmp_path))
    assert exit_.value.code == 2
    assert "the folder's name must be a domain" in capsys.readouterr().err


def test_a_rerun_that_keeps_every_task_keeps_the_recorded_data(tmp_path: Path) -> None:
    demos, experts = tmp_path / "cheetah", tmp_path / "experts"
    demos.mkdir()
    _expert(
        experts / "walk", "fbil expert cheetah walk --mode online --data datasets/cheetah/rnd", 5.0
    )
    _demos(demos / "walk.npz", "TD3 expert walk", [800.0])
    experts_table.main(str(demos), str(experts))
    elsewhere = tmp_path / "elsewhere"  # the experts' folders are not on this machine
    elsewhere.mkdir()
    experts_table.main(str(demos), str(elsewhere))
    assert json.loads((demos / "experts.json").read_text())["tasks"]["walk"]["return_mean"] == 800.0
    assert json.loads((demos / "manifest.json").read_text())["data"] == "datasets/cheetah/rnd"
