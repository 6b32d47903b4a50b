"""scripts/experts.sh builds each task's expert and demo commands (checked with DRY=1, which
prints them without running anything), and walker's recorded script is the same path."""

import os
import subprocess
from pathlib import Path

ROOT = Path(__file__).parents[1]


def _dry(script: str, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["bash", str(ROOT / "scripts" / script), *args],
        env={**os.environ, "DRY": "1", **env},
        capture_output=True,
        text=True,
    )


def _commands(out: subprocess.CompletedProcess[str]) -> list[str]:
    return [line[2:] for line in out.stdout.splitlines() if line.startswith("+ ")]


def test_every_task_of_the_domain_gets_an_expert_and_two_demo_files(tmp_path: Path) -> None:
    out = _dry("experts.sh", "cheetah", str(tmp_path / "runs"), str(tmp_path / "demos"))
    assert out.returncode == 0, out.stderr
    commands = _commands(out)
    experts = [c.split()[3] for c in commands if c.startswith("fbil expert ")]
    assert experts == ["run", "run_backward", "walk", "walk_backward"]
    assert sum(c.startswith("fbil demos ") for c in commands) == 8
    assert all("--data" not in c for c in commands)
    assert not (tmp_path / "runs").exists()  # a dry run makes no folders


def test_prior_data_budgets_and_task_subsets_reach_the_expert_command(tmp_path: Path) -> None:
    out = _dry(
        "experts.sh",
        "cheetah",
        str(tmp_path),
        str(tmp_path),
        TASKS="walk run",
        DATA="datasets/cheetah/rnd",
        STEPS_run="500000",
    )
    assert out.returncode == 0, out.stderr
    experts = [c for c in _commands(out) if c.startswith("fbil expert ")]
    assert [c.split()[3] for c in experts] == ["walk", "run"]
    assert all(c.endswith("--data datasets/cheetah/rnd") for c in experts)
    assert "--steps 300000" in experts[0] and "--steps 500000" in experts[1]


def test_demo_physics_reaches_both_demo_commands(tmp_path: Path) -> None:
    """DEMO_PHYSICS=first keeps one demo's physics per file (quadruped's large files);
    by default every demo keeps them."""
    first = _dry("experts.sh", "quadruped", str(tmp_path), str(tmp_path), TASKS="stand",
                 DEMO_PHYSICS="first")  # fmt: skip
    default = _dry("experts.sh", "quadruped", str(tmp_path), str(tmp_path), TASKS="stand")
    for out, value in ((first, "first"), (default, "all")):
        demos = [c for c in _commands(out) if c.startswith("fbil demos ")]
        assert len(demos) == 2 and all(c.endswith(f"--physics {value}") for c in demos)


def test_walker_script_is_the_generic_one_for_walker(tmp_path: Path) -> None:
    args = (str(tmp_path / "runs"), str(tmp_path / "demos"), "1")
    walker = _dry("walker_experts.sh", *args)
    generic = _dry("experts.sh", "walker", *args)
    assert walker.returncode == generic.returncode == 0
    assert _commands(walker) == _commands(generic)
    assert [c.split()[3] for c in _commands(walker) if c.startswith("fbil expert ")] == [
        "stand",
        "walk",
        "run",
        "flip",
        "spin",
    ]


def test_unknown_domains_and_tasks_are_refused_in_one_line(tmp_path: Path) -> None:
    bad_domain = _dry("experts.sh", "walkr", str(tmp_path))
    assert bad_domain.returncode == 2
    assert bad_domain.stderr.strip().splitlines() == [
        "error: unknown domain 'walkr'; `fbil tasks` lists the domains"
    ]
    bad_task = _dry("experts.sh", "cheetah", str(tmp_path), TASKS="run jump")
    assert bad_task.returncode == 2 and "unknown cheetah task 'jump'" in bad_task.stderr
    assert _commands(bad_task) == []
