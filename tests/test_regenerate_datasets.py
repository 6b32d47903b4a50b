"""scripts/regenerate_datasets.sh runs exactly the commands the dataset manifests record
(checked with DRY=1, which prints them without running anything)."""

import json
import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).parents[1]
SCRIPT = ROOT / "scripts" / "regenerate_datasets.sh"


def _dry(domain: str) -> tuple[int, list[str]]:
    out = subprocess.run(
        ["bash", str(SCRIPT), domain],
        env={**os.environ, "DRY": "1"},
        capture_output=True,
        text=True,
    )
    return out.returncode, [line[2:] for line in out.stdout.splitlines() if line.startswith("+ ")]


def _manifest(domain: str) -> dict[str, str]:
    return json.loads((ROOT / "artifacts" / "datasets" / domain / "manifest.json").read_text())


def test_maze_commands_are_the_recorded_regeneration() -> None:
    rc, commands = _dry("point_mass_maze")
    assert rc == 0
    recorded = re.findall(
        r"(fbil (?:collect|dataset-oversample) [^;]+?)(?:;|$)",
        _manifest("point_mass_maze")["regeneration_check"],
    )
    assert len(recorded) == 3
    assert all(c in commands for c in recorded), (recorded, commands)
    assert commands.index(recorded[0]) < commands.index(recorded[1]) < commands.index(recorded[2])


def test_walker_command_is_the_recorded_collection() -> None:
    rc, commands = _dry("walker")
    assert rc == 0
    assert commands == [_manifest("walker")["dataset_manifest"]["command"]]


def test_cheetah_command_is_the_recorded_collection() -> None:
    rc, commands = _dry("cheetah")
    assert rc == 0
    assert commands == [_manifest("cheetah")["dataset_manifest"]["command"]]


def test_a_domain_without_a_recipe_is_refused() -> None:
    out = subprocess.run(["bash", str(SCRIPT), "quadruped"], capture_output=True, text=True)
    assert out.returncode == 2 and "no regeneration recipe" in out.stderr


def test_maze_mixed_data_commands_are_the_recorded_ones() -> None:
    rc, commands = _dry("point_mass_maze")
    assert rc == 0
    recorded = [
        c.strip()
        for c in re.findall(
            r"fbil (?:collect|dataset-merge) [^;(]+", _manifest("point_mass_maze")["mixed_command"]
        )
    ]
    assert len(recorded) == 3
    assert all(c in commands for c in recorded), (recorded, commands)
    # each is checked against a committed dataset-info
    names = ("random_uniform_200", "rnd1000_random200", "rnd_x4_random200")
    assert f"for n in {' '.join(names)}; do" in SCRIPT.read_text()
    info = ROOT / "artifacts" / "datasets" / "point_mass_maze"
    assert all((info / f"info_{name}.json").is_file() for name in names)
