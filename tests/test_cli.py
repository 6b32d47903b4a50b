"""The command line as a user runs it: a real subprocess, real files."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.envs.test_registry import EXPECTED


def fbil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fbil", *args], capture_output=True, text=True, timeout=300
    )


def test_tasks_json_lists_the_21_tasks_with_sizes() -> None:
    res = fbil("tasks", "--json")
    assert res.returncode == 0, res.stderr
    domains = json.loads(res.stdout)["domains"]
    assert {d: (v["obs_dim"], v["act_dim"], v["tasks"]) for d, v in domains.items()} == EXPECTED


def test_tasks_table_is_readable() -> None:
    res = fbil("tasks")
    assert res.returncode == 0 and "21 tasks" in res.stdout and "fast_slow" in res.stdout


@pytest.mark.parametrize(
    "args, names",
    [
        (["render", "humanoid", "run", "--out", "x.png"], "point_mass_maze, walker"),
        (["render", "walker", "backflip", "--out", "x.png"], "stand, walk, run, flip, spin"),
        (["render", "walker", "walk", "--policy", "expert", "--out", "x.png"], "random"),
        (["render", "walker", "walk", "--out", "x.bmp"], ".gif"),
    ],
)
def test_bad_names_give_one_line_and_exit_2(args: list[str], names: str, tmp_path: Path) -> None:
    res = fbil(*args)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fbil: error:") and names in lines[0]
    assert "Traceback" not in res.stderr


def test_render_maze_and_locomotion(tmp_path: Path) -> None:
    maze = tmp_path / "maze.png"
    res = fbil(
        "render", "point_mass_maze", "square", "--out", str(maze), "--steps", "100", "--json"
    )
    assert res.returncode == 0, res.stderr
    payload = json.loads(res.stdout)
    assert payload["out"] == str(maze) and len(payload["returns"]) == 5
    assert maze.read_bytes()[:4] == b"\x89PNG"
    strip = tmp_path / "cheetah.png"
    res = fbil("render", "cheetah", "run", "--out", str(strip), "--steps", "20", "--frames", "3")
    assert res.returncode == 0, res.stderr
    assert strip.stat().st_size > 1000


FIXTURE = Path(__file__).parent / "fixtures" / "exorl" / "point_mass_maze" / "rnd"


def test_dataset_info_reports_coverage_and_plots(tmp_path: Path) -> None:
    import shutil

    data = tmp_path / "maze"
    shutil.copytree(FIXTURE, data)
    plot = tmp_path / "cov.png"
    res = fbil("dataset-info", str(data), "--plot", str(plot), "--json")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["episodes"] == 4 and info["transitions"] == 4000
    cov = info["coverage"]
    assert 0 < cov["grid_fraction"] <= 1 and "top_left" in cov["rooms_visited"]
    assert plot.read_bytes()[:4] == b"\x89PNG"


def test_dataset_merge_from_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "both"
    res = fbil("dataset-merge", str(FIXTURE), str(FIXTURE), "--out", str(out), "--json")
    assert res.returncode == 0, res.stderr
    manifest = json.loads(res.stdout)
    assert manifest["episodes"] == 8 and manifest["command"].startswith("fbil dataset-merge")
    info = json.loads(fbil("dataset-info", str(out), "--json").stdout)
    assert info["episodes"] == 8 and info["transitions"] == 8000


def test_dataset_errors_are_one_line(tmp_path: Path) -> None:
    import shutil

    data = tmp_path / "maze"
    shutil.copytree(FIXTURE, data)
    bad = sorted((data / "buffer").glob("*.npz"))[2]
    bad.write_bytes(bad.read_bytes()[:500])
    for args, expected in [
        (["dataset-info", str(tmp_path / "nothing")], "no dataset at"),
        (["dataset-info", str(data)], bad.name),
        (["dataset-info", str(FIXTURE), "--domain", "walker"], "not walker"),
        (["dataset-merge", str(FIXTURE), str(data), "--out", str(data)], "already exists"),
        (["dataset-oversample", str(FIXTURE), "--out", str(tmp_path / "o")], "changes room"),
        (["collect", "humanoid", "--episodes", "1", "--out", str(tmp_path / "h")], "valid domains"),
    ]:
        res = fbil(*args)
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 2 and len(lines) == 1 and expected in lines[0], res.stderr


# Every command's output path, unwritable even for root (tests may run as root, for whom
# a chmod 555 folder is writable): under an existing *file* ("file"), or in /proc, where
# no one can make files ("proc"). The other inputs don't exist: an error naming anything
# but the output would show that work began before the output was checked.
UNWRITABLE = {
    "imitate": ["imitate", "{gone}/model", "{gone}/demos.npz", "--out", "{out}"],
    "evaluate": ["evaluate", "{gone}/model", "{gone}/demos.npz", "--out", "{out}.json"],
    "benchmark": [
        *("benchmark", "--domain", "point_mass_maze", "--model", "{gone}/model"),
        *("--demos", "{gone}", "--workers", "2", "--out", "{out}.jsonl"),
    ],
    "demo": ["demo", "--out", "{out}"],  # with FBIL_ARTIFACTS pointing nowhere
    "render": ["render", "point_mass_maze", "square", "--out", "{out}.png"],
    "report": ["report", "{gone}/results.jsonl", "--out", "{out}"],
    "collect": ["collect", "point_mass_maze", "--episodes", "1", "--out", "{out}"],
    "pretrain": ["pretrain", "point_mass_maze", "--data", "{gone}", "--out", "{out}"],
    "pretrain-goal": ["pretrain-goal", "point_mass_maze", "--data", "{gone}", "--out", "{out}"],
    "expert": ["expert", "point_mass_maze", "loop", "--data", "{gone}", "--out", "{out}"],
    "demos": ["demos", "{gone}/expert", "--episodes", "1", "--out", "{out}.npz"],
    "dataset-info": ["dataset-info", "{gone}", "--plot", "{out}.png"],
    "dataset-merge": ["dataset-merge", "{gone}", "--out", "{out}"],
    "dataset-oversample": ["dataset-oversample", "{gone}", "--out", "{out}"],
}


@pytest.mark.parametrize(
    "command, where",
    [(c, "file") for c in sorted(UNWRITABLE)]
    + [(c, "proc") for c in ("imitate", "benchmark", "demo")],
)
def test_an_unwritable_output_stops_the_command_before_any_work(
    command: str, where: str, tmp_path: Path
) -> None:
    import os

    (tmp_path / "a_file").write_text("")
    parent = tmp_path / "a_file" if where == "file" else Path("/proc/fbil-test")
    out = str(parent / "out")
    gone = str(tmp_path / "missing")
    args = [a.format(out=out, gone=gone) for a in UNWRITABLE[command]]
    env = {**os.environ, "FBIL_ARTIFACTS": gone}
    res = subprocess.run(
        [sys.executable, "-m", "fbil", *args], capture_output=True, text=True, env=env, timeout=60
    )
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert lines[0].startswith("fbil: error: cannot write") and out in lines[0], lines[0]
    assert "choose another" in lines[0] and "missing" not in lines[0]
    assert res.stdout == "" and sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_one_spelling_per_option_and_every_default_in_help() -> None:
    import argparse

    from fbil.cli import build_parser

    (sub,) = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    for name, parser in sub.choices.items():
        actions = [a for a in parser._actions if a.option_strings]
        options = {o for a in actions for o in a.option_strings}
        old = {"--method", "--demos-per-run", "--repetitions", "--task", "--start"} & options
        assert not old, f"{name}: {old}"
        text = " ".join(parser.format_help().split())
        for a in actions:
            if a.default is not None and a.default is not False and a.default != argparse.SUPPRESS:
                shown = f"(default: {a.default})"
                assert text.count(f"{shown} {shown}") == 0, f"{name} {a.option_strings} twice"
                assert shown in text, f"{name} {a.option_strings}"
        if "--threads" in options:  # several fbil processes must not fight over the cores
            assert parser.get_default("threads") == 1


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["imitate", "no-model", "{demos}", "--methods", "bc", "--k", "0"],
            "--k must be in [1, 1]",
        ),
        # more demos asked for than the file has: an error, as in `fbil evaluate`
        (
            ["imitate", "no-model", "{demos}", "--methods", "bc", "--k", "2"],
            "--k must be in [1, 1]",
        ),
        (
            ["pretrain-goal", "point_mass_maze", "--data", "x", "--out", "{out}", "--set"],
            "'abc' is not a valid number",
        ),
    ],
)
def test_bad_values_are_one_line_errors(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import numpy as np

    from fbil.cli import main
    from fbil.imitation import Demos, from_arrays

    rng = np.random.default_rng(0)
    obs = [rng.uniform(-0.2, 0.2, (11, 4)).astype(np.float32)]
    demos = from_arrays(obs, [rng.uniform(-1, 1, (10, 2)).astype(np.float32)])
    Demos(demos.trajectories, {"domain": "point_mass_maze", "task": "square"}).save(
        tmp_path / "d.npz"
    )
    filled = [a.format(demos=tmp_path / "d.npz", out=tmp_path / "out") for a in args]
    extra = ["--budget", "smoke"] if args[0] == "imitate" else ["epsilon=abc"]
    assert main([*filled, *extra]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fbil: error:") and message in lines[0]


@pytest.mark.parametrize(
    "args, message",
    [
        (["demo", "--methods", "td3il"], "fbil demo runs the shipped FB model's methods"),
        (["pretrain", "walker", "--data", "x", "--out", "{out}", "--steps", "0"], "steps must be"),
        (["pretrain-goal", "walker", "--data", "x", "--out", "{out}", "--steps", "0"], "steps"),
    ],
)
def test_out_of_range_requests_are_refused_before_work(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from fbil.cli import main

    assert main([a.format(out=tmp_path / "out") for a in args]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fbil: error:") and message in lines[0]
    assert not (tmp_path / "out").exists()


def test_report_refuses_results_that_mix_budgets(tmp_path: Path) -> None:
    from fbil.errors import FbilError
    from fbil.evaluation.report import summarise

    row = {"domain": "point_mass_maze", "demo_set": "standard", "k": 1, "method": "bc"}
    rows = [
        {**row, "task": "loop", "draw": 0, "score": 0.5, "budget": "cpu"},
        {**row, "task": "loop", "draw": 0, "score": 0.1, "budget": "smoke"},
    ]
    with pytest.raises(FbilError, match="several budgets of bc"):
        summarise(rows)


@pytest.mark.parametrize(
    "device, message",
    [("gpu", "expected cpu, cuda or cuda:N"), ("cuda:x", "expected cpu"), ("cpu:1", "expected")],
)
def test_pretrain_refuses_an_unknown_device_in_one_line(
    device: str,
    message: str,
    fixture_data: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from fbil.cli import main

    args = ["pretrain", "point_mass_maze", "--data", str(fixture_data), "--preset", "smoke"]
    assert main([*args, "--out", str(tmp_path / "out"), "--device", device]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fbil: error:") and message in lines[0]
    assert not (tmp_path / "out").exists()


def test_cuda_without_a_device_and_the_gpu_precision_note() -> None:
    from fbil.cli import _check_device, _device_note
    from fbil.errors import FbilError

    _check_device("cuda:1", cuda_available=True)
    with pytest.raises(FbilError, match="no CUDA device here; use --device cpu"):
        _check_device("cuda", cuda_available=False)
    assert _device_note("cpu", "bf16", compile=True) is None
    assert _device_note("cuda", "fp32", compile=True) is None
    assert "precision=fp32" in (_device_note("cuda", "bf16", compile=False) or "")
    assert "0.14 updates/s" in (_device_note("cuda:0", "bf16", compile=True) or "")
