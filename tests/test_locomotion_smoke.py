"""The locomotion path end to end at smoke size, through the command line as a user runs
it, on walker (issue #21) and on the two domains that follow it, cheetah and quadruped:
collect 2 RND episodes -> pretrain `smoke` -> a 20-step online expert -> its standard and
shifted demonstrations -> imitate with the eight FB-IL methods -> evaluate 1 episode -> a
1-job benchmark grid -> its report. Also the shifted-start construction: a shifted
demonstration starts where the expert's standard rollout from the same seed is at step 500
(paper App. E.5)."""

from __future__ import annotations

import json
import math
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fbil.envs import get_domain, make_env
from fbil.envs.locomotion import SHIFT_STEP
from fbil.evaluation.paper import PAPER_RETURNS
from fbil.imitation import Demos

# One task a domain: walker's of issue #21, and a task of each domain that follows it.
TASKS = {"walker": "stand", "cheetah": "run", "quadruped": "stand"}
EPISODE = 1000  # the locomotion episode length, every rollout below
# `--methods all`: the paper's eight FB-IL methods.
FB_IL = ("erfb", "rerfb", "bcfb", "fmfb", "dmfb", "bbellfb", "fblossfb", "goalfb")


class Fbil:
    """`fbil COMMAND` started in `cwd` (paths relative to it). Its output goes to files
    under cwd/logs, so that commands can run side by side without blocking on a pipe."""

    def __init__(self, cwd: Path, command: str) -> None:
        self.command = command
        logs = cwd / "logs"
        logs.mkdir(exist_ok=True)
        n = len(list(logs.glob("*.out")))  # commands started so far
        self.out, self.err = logs / f"{n}.out", logs / f"{n}.err"
        args = [sys.executable, "-m", "fbil", *shlex.split(command)]
        with open(self.out, "w") as out, open(self.err, "w") as err:
            self.proc = subprocess.Popen(args, cwd=cwd, stdout=out, stderr=err)

    def result(self) -> str:
        """Wait for the command; its stdout (the JSON object where --json is passed)."""
        try:
            code = self.proc.wait(timeout=300)
        finally:
            self.proc.kill()  # a no-op once it has exited
        stderr = self.err.read_text()[-3000:]
        assert code == 0, f"fbil {self.command} failed:\n{stderr}"
        return self.out.read_text()


def fbil(cwd: Path, command: str) -> str:
    return Fbil(cwd, command).result()


@pytest.fixture(scope="module", params=sorted(TASKS))
def domain(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def run(domain: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with the dataset D, the model M, the expert E and its demos (2 each); the
    expert trains while the data is collected and the model pre-trained."""
    cwd = tmp_path_factory.mktemp(domain)
    # A smoke expert: 10 random-action steps, then a TD3 update per step (and two
    # 10-episode evaluations, the bulk of its time).
    tiny = "--steps 20 --start-steps 10 --eval-every 20"
    expert = Fbil(cwd, f"expert {domain} {TASKS[domain]} --mode online --out E {tiny}")
    collect = f"collect {domain} --explorer rnd --episodes 2 --out D --num-envs 2 --agents 1"
    collected = json.loads(fbil(cwd, f"{collect} --json"))
    assert collected["episodes"] == 2 and collected["transitions"] == 2 * EPISODE
    fbil(cwd, f"pretrain {domain} --data D --preset smoke --out M")
    expert.result()
    shifted = Fbil(cwd, "demos E --episodes 2 --out shifted.npz --starts shifted")
    fbil(cwd, "demos E --episodes 2 --out demos.npz")
    shifted.result()
    return cwd


def test_each_stage_writes_what_the_next_one_reads(domain: str, run: Path) -> None:
    spec = get_domain(domain)
    assert len(list((run / "D" / "buffer").glob("*_1000.npz"))) == 2
    assert (run / "M" / "model.safetensors").is_file()
    config = json.loads((run / "M" / "config.json").read_text())
    assert (config["model"]["obs_dim"], config["model"]["act_dim"]) == (
        spec.obs_dim,
        spec.act_dim,
    )
    expert = json.loads((run / "E" / "expert.json").read_text())
    assert (expert["domain"], expert["task"], expert["mode"]) == (domain, TASKS[domain], "online")
    assert expert["steps"] == 20 and math.isfinite(expert["return_mean"])
    for name, start in (("demos.npz", "standard"), ("shifted.npz", "shifted")):
        demos = Demos.load(run / name)
        assert demos.metadata["domain"] == domain and demos.metadata["start"] == start
        assert len(demos.trajectories) == 2
        shape = (EPISODE + 1, spec.obs_dim)
        assert all(t.observation.shape == shape for t in demos.trajectories)
        assert np.isfinite(demos.metadata["returns"]).all()


def test_shifted_demos_start_at_step_500_of_the_experts_standard_rollout(
    domain: str, run: Path
) -> None:
    """Both demo files roll the same expert out from the same seeds, so the standard
    demonstration is the expert's standard rollout the shifted starts are taken from."""
    standard = Demos.load(run / "demos.npz").trajectories
    shifted = Demos.load(run / "shifted.npz").trajectories
    env = make_env(domain, TASKS[domain])
    for std, sh in zip(standard, shifted, strict=True):
        assert std.physics is not None and sh.physics is not None
        np.testing.assert_array_equal(sh.physics[0], std.physics[SHIFT_STEP])
        # The first observation is the environment's at that physics state ...
        np.testing.assert_array_equal(sh.observation[0], env.set_physics_state(sh.physics[0]))
        if domain != "quadruped":
            # ... and the standard rollout's, except where acceleration-stage sensors read
            # one step late after a normal step (quadruped; FbilEnv.set_physics_state).
            np.testing.assert_array_equal(sh.observation[0], std.observation[SHIFT_STEP])
        assert not np.array_equal(sh.physics[0], std.physics[0])  # not the standard start
    # The two seeds' bodies are in different places at step 500: starts pair by seed.
    assert not np.array_equal(shifted[0].physics[0], shifted[1].physics[0])


def test_imitate_gives_a_policy_per_fb_il_method(run: Path) -> None:
    out = json.loads(fbil(run, "imitate M demos.npz --methods all --out P --json"))
    assert sorted(out["methods"]) == sorted(FB_IL)
    for m in FB_IL:
        assert math.isfinite(out["methods"][m]["seconds"])
        saved = json.loads((run / "P" / f"{m}.json").read_text())
        assert saved["method"] == m and np.isfinite(saved["z"]).all()


def test_evaluate_scores_one_episode_per_method(domain: str, run: Path) -> None:
    out = json.loads(fbil(run, "evaluate M demos.npz --methods erfb,goalfb --episodes 1 --json"))
    expert = Demos.load(run / "demos.npz").metadata["return_mean"]
    assert (out["task"], out["episodes"], out["k"]) == (TASKS[domain], 1, 1)
    assert out["expert_return"] == pytest.approx(expert)
    assert set(out["methods"]) == {"erfb", "goalfb"}
    for r in out["methods"].values():
        assert math.isfinite(r["return_mean"]) and r["return_mean"] >= 0
        assert r["score"] == pytest.approx(r["return_mean"] / expert)


def test_a_one_job_benchmark_and_its_report(domain: str, run: Path) -> None:
    task = TASKS[domain]
    (run / "DD").mkdir()
    shutil.copy(run / "demos.npz", run / "DD" / f"{task}.npz")
    grid = f"--tasks {task} --methods erfb --draws 1 --episodes 1"
    fbil(run, f"benchmark --domain {domain} --model M --demos DD {grid} --out res.jsonl --quiet")
    (row,) = [json.loads(line) for line in (run / "res.jsonl").read_text().splitlines()]
    assert (row["domain"], row["task"], row["method"], row["draw"]) == (domain, task, "erfb", 0)
    assert len(row["returns"]) == 1 and math.isfinite(row["returns"][0])
    fbil(run, "report res.jsonl --out R")
    text = (run / "R" / "report.md").read_text()
    assert text.startswith(f"# fbil benchmark report: {domain}")
    assert "| erfb | reward inference |" in text
    paper = PAPER_RETURNS[domain]  # the paper's expert and ERFB returns on the task
    assert f"({paper['expert'][task]:.1f})" in text and f"({paper['erfb'][task]:.1f})" in text
    assert (run / "R" / f"trajectories_{task}.png").stat().st_size > 1000
