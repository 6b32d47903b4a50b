"""The evaluation protocol, the resumable benchmark grid and the report, on a real (smoke)
FB model, real maze episodes as demonstrations, and real files."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fbil.data import list_episodes, load_episode
from fbil.envs.relabel import relabel
from fbil.errors import FbilError
from fbil.evaluation.benchmark import make_jobs, read_results, run_benchmark
from fbil.evaluation.evaluate import evaluate, rollout_policies
from fbil.evaluation.report import write_report
from fbil.fb.model import FBModel
from fbil.imitation import Demos, Trajectory, imitate

TASKS = ("reach_top_left", "square")


@pytest.fixture(scope="module")
def demos_dir(fixture_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """<task>.npz for two maze tasks: fixture episodes relabeled with each task's reward."""
    out = tmp_path_factory.mktemp("demos")
    episodes = [load_episode(f.path) for f in list_episodes(fixture_data)[:2]]
    for task in TASKS:
        trajs = []
        for ep in episodes:
            reward = relabel("point_mass_maze", task, ep["physics"][1:], ep["action"][1:])
            trajs.append(Trajectory(ep["observation"], ep["action"][1:], reward.astype(np.float32)))
        returns = [float(t.reward.sum()) for t in trajs]  # type: ignore[union-attr]
        meta = {"domain": "point_mass_maze", "task": task, "return_mean": float(np.mean(returns))}
        Demos(trajs, meta).save(out / f"{task}.npz")
    return out


def test_scores_are_returns_over_the_expert_and_reproducible(
    smoke_model_dir: Path, demos_dir: Path
) -> None:
    model = FBModel.load(smoke_model_dir)
    demos = Demos.load(demos_dir / "square.npz")
    a = evaluate(model, demos, "erfb,goalfb", episodes=2, seed=3)
    b = evaluate(model, demos, ["erfb", "goalfb"], episodes=2, seed=3)
    assert a["expert_return"] == pytest.approx(demos.metadata["return_mean"])
    for m in ("erfb", "goalfb"):
        r = a["results"][m]
        assert r.score == pytest.approx(r.return_mean / a["expert_return"])
        assert r.returns == b["results"][m].returns  # same seed, same episodes


def test_batched_methods_equal_each_method_alone(smoke_model_dir: Path, demos_dir: Path) -> None:
    """Playing several policies side by side changes nothing for each of them."""
    model = FBModel.load(smoke_model_dir)
    demos = Demos.load(demos_dir / "reach_top_left.npz").select([0])
    policies = [imitate(model, demos, m) for m in ("erfb", "goalfb")]
    together = rollout_policies(policies, "point_mass_maze", "reach_top_left", 2, seed=1)
    for i, p in enumerate(policies):
        alone = rollout_policies([p], "point_mass_maze", "reach_top_left", 2, seed=1)
        np.testing.assert_allclose(together.returns[2 * i : 2 * i + 2], alone.returns)


def test_bad_requests_are_one_line_errors(smoke_model_dir: Path, demos_dir: Path) -> None:
    model = FBModel.load(smoke_model_dir)
    demos = Demos.load(demos_dir / "square.npz")
    with pytest.raises(FbilError, match="unknown method"):
        evaluate(model, demos, "erfb,nope", episodes=1)
    with pytest.raises(FbilError, match="--k must be in"):
        evaluate(model, demos, "erfb", k=5, episodes=1)
    no_task = Demos(demos.trajectories, {"domain": "point_mass_maze"})
    with pytest.raises(FbilError, match="domain and task"):
        evaluate(model, no_task, "erfb", episodes=1)
    with pytest.raises(FbilError, match="no demonstrations for loop"):
        make_jobs(smoke_model_dir, demos_dir, "point_mass_maze", ["loop"], ["erfb"], 1, 1, 1)


def test_first_draw_selects_the_same_jobs_as_the_full_grid(
    smoke_model_dir: Path, demos_dir: Path
) -> None:
    def grid(draws: int, first: int = 0) -> list[Any]:
        return make_jobs(
            smoke_model_dir,
            demos_dir,
            "point_mass_maze",
            ["square"],
            ["erfb"],
            draws,
            1,
            1,
            first_draw=first,
        )

    assert [j.draw for j in grid(2, first=2)] == [2, 3]
    assert grid(2, first=2) == grid(4)[2:]  # same jobs, hence the same results-file keys
    with pytest.raises(FbilError, match="--first-draw must be >= 0"):
        grid(1, first=-1)


def _benchmark_cmd(model: Path, demos: Path, out: Path, *extra: str) -> list[str]:
    """The 2 x 2 x 1 grid of 2-episode jobs; `extra` options replace those before them."""
    return [
        sys.executable,
        "-m",
        "fbil",
        "benchmark",
        "--domain",
        "point_mass_maze",
        "--model",
        str(model),
        "--demos",
        str(demos),
        "--tasks",
        ",".join(TASKS),
        "--methods",
        "erfb,goalfb",
        "--draws",
        "1",
        "--episodes",
        "2",
        "--out",
        str(out),
        "--quiet",
        *extra,
    ]


def test_benchmark_killed_and_resumed_runs_every_job_once(
    smoke_model_dir: Path, demos_dir: Path, tmp_path: Path
) -> None:
    out = tmp_path / "results.jsonl"
    cmd = _benchmark_cmd(smoke_model_dir, demos_dir, out)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        if out.exists() and out.read_text().count("\n") >= 1:
            break
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    killed_with = out.read_text().count("\n")
    assert 1 <= killed_with < 4, "the grid must be interrupted part-way for this test"
    with open(out, "a") as fh:  # a line cut by the kill while being written
        fh.write('{"model": "cut mid-wri')
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    rows = read_results(out)
    keys = [(r["task"], r["method"], r["draw"]) for r in rows]
    assert sorted(keys) == sorted((t, m, 0) for t in TASKS for m in ("erfb", "goalfb"))
    assert all(r["commit"] and r["episodes"] == 2 and len(r["returns"]) == 2 for r in rows)
    assert all(len(r["trajectory"]) > 100 for r in rows)  # maze, draw 0: a path to draw
    # Rerunning a finished grid runs nothing.
    assert (
        run_benchmark(
            make_jobs(
                smoke_model_dir, demos_dir, "point_mass_maze", TASKS, ["erfb", "goalfb"], 1, 1, 2
            ),
            out,
        )
        == []
    )

    report = write_report(out, tmp_path / "report")
    text = report.read_text()
    assert "| erfb | reward inference |" in text and "(771.9)" in text  # paper ERFB, square
    assert (tmp_path / "report" / "trajectories_square.png").stat().st_size > 1000
    assert (tmp_path / "report" / "time_to_policy.png").is_file()
    # The bounds section: the expert against the paper's, and the model's zero-shot return.
    zero_shot = smoke_model_dir / "zero_shot.json"
    zero_shot.write_text(json.dumps({"tasks": {"square": {"return_mean": 123.45}}}))
    try:
        text = write_report(out, tmp_path / "report").read_text()
    finally:
        zero_shot.unlink()
    (row,) = [line for line in text.splitlines() if line.startswith("| square | ")]
    expert = next(r["expert_return"] for r in rows if r["task"] == "square")
    assert f"| {expert:.1f} | 952.9 | {100 * expert / 952.9:.1f} % | 123.5 |" in row


def _session_processes(sid: int) -> list[int]:
    """Live (not zombie) processes of session `sid`, from /proc."""
    pids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue  # the process ended while being read
        if int(fields[3]) == sid and fields[0] != "Z":
            pids.append(int(stat.parent.name))
    return pids


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_ctrl_c_stops_a_parallel_benchmark_at_once_and_resume_completes_it(
    smoke_model_dir: Path, demos_dir: Path, tmp_path: Path
) -> None:
    """Ctrl-C, as a terminal sends it (SIGINT to the whole process group), on a 32-job grid
    run by 2 workers: exit within 5 s, no process left behind, finished lines kept; the
    resumed grid then holds every job exactly once. (32 jobs, not 16: on an idle machine a
    16-job grid once ended before the interrupt reached it.)"""
    out = tmp_path / "results.jsonl"
    draws = 8
    grid = ("--draws", str(draws), "--episodes", "1", "--workers", "2")
    cmd = _benchmark_cmd(smoke_model_dir, demos_dir, out, *grid)
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        deadline = time.time() + 240
        while time.time() < deadline and proc.poll() is None:
            if out.exists() and out.read_text().count("\n") >= 1:
                break
            time.sleep(0.02)
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        lines_before = out.read_text().splitlines()
        os.killpg(proc.pid, signal.SIGINT)
        started = time.monotonic()
        _, stderr = proc.communicate(timeout=30)
        assert time.monotonic() - started < 5
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130 and stderr.strip() == "fbil: interrupted", stderr
    deadline = time.time() + 2  # the multiprocessing resource tracker sees its pipe close
    while _session_processes(proc.pid) and time.time() < deadline:
        time.sleep(0.05)
    assert _session_processes(proc.pid) == []
    kept = out.read_text().splitlines()
    assert 1 <= len(kept) < len(TASKS) * 2 * draws and kept[: len(lines_before)] == lines_before
    assert all(json.loads(line)["returns"] for line in kept)  # whole lines only
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    keys = [(r["task"], r["method"], r["draw"]) for r in read_results(out)]
    expected = [(t, m, d) for t in TASKS for m in ("erfb", "goalfb") for d in range(draws)]
    assert sorted(keys) == sorted(expected)


def test_evaluate_writes_its_json_to_out(
    smoke_model_dir: Path, demos_dir: Path, tmp_path: Path
) -> None:
    out = tmp_path / "scores" / "square.json"
    args = [str(smoke_model_dir), str(demos_dir / "square.npz"), "--methods", "erfb"]
    options = ["--episodes", "1", "--json", "--out", str(out)]
    res = subprocess.run(
        [sys.executable, "-m", "fbil", "evaluate", *args, *options],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    assert json.loads(out.read_text()) == json.loads(res.stdout)
    assert set(json.loads(res.stdout)["methods"]) == {"erfb"}


def test_results_files_that_cannot_be_trusted_are_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"a": 1}\nnot json\n{"b": 2}\n')
    with pytest.raises(FbilError, match="line 2 is not valid JSON"):
        read_results(bad)
    mixed = tmp_path / "mixed.jsonl"
    rows = [
        {
            "domain": d,
            "task": "t",
            "method": "erfb",
            "demo_set": "standard",
            "k": 1,
            "draw": 0,
            "score": 0.5,
            "return_mean": 1.0,
            "expert_return": 2.0,
            "seconds": 0.1,
        }
        for d in ("walker", "point_mass_maze")
    ]
    mixed.write_text("".join(json.dumps(r) + "\n" for r in rows))
    with pytest.raises(FbilError, match="mix domains"):
        write_report(mixed, tmp_path / "r")
    assert not (tmp_path / "r" / "report.md").exists()


def test_the_ray_backend_runs_the_same_grid(
    smoke_model_dir: Path, demos_dir: Path, tmp_path: Path
) -> None:
    pytest.importorskip("ray")
    jobs = make_jobs(smoke_model_dir, demos_dir, "point_mass_maze", TASKS[:1], ["erfb"], 1, 1, 1)
    local = run_benchmark(jobs, tmp_path / "local.jsonl")
    remote = run_benchmark(jobs, tmp_path / "ray.jsonl", workers=1, backend="ray")
    assert [r["returns"] for r in remote] == [r["returns"] for r in local]


def test_only_the_lines_the_report_draws_keep_a_trajectory(
    smoke_model_dir: Path, demos_dir: Path, tmp_path: Path
) -> None:
    """A trajectory is most of a line's bytes: the K = 1 standard grid's first draw keeps
    one (the report draws it), K > 1 lines and later draws do not."""

    def grid(draws: int, k: int) -> list[dict]:
        jobs = make_jobs(
            smoke_model_dir, demos_dir, "point_mass_maze", TASKS[:1], ["erfb"], draws, k, 1
        )
        return run_benchmark(jobs, tmp_path / f"k{k}.jsonl")

    assert [("trajectory" in r, r["draw"]) for r in grid(2, 1)] == [(True, 0), (False, 1)]
    assert ["trajectory" in r for r in grid(1, 2)] == [False]
