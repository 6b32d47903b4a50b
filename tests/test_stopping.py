"""A clean stop (Ctrl-C / SIGTERM) saves the checkpoint at the step it stopped, and a
resume from it equals a run that never stopped."""

import dataclasses
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import torch

from fbil.checkpoint import load_state
from fbil.data import load_dataset
from fbil.stopping import StopSignals, TrainingStopped


def _signal_at(step_of: Any, update: Any, at: int, signum: int) -> Any:
    """`update` wrapped to send this process `signum` right after the update that ends at `at`."""

    def wrapped(*args: Any, **kwargs: Any) -> Any:
        out = update(*args, **kwargs)
        if step_of() == at:
            signal.raise_signal(signum)
        return out

    return wrapped


def _fb_trainer(data: Path, steps: int) -> Any:
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    train_cfg = dataclasses.replace(train_cfg, steps=steps, checkpoint_seconds=1e9)
    return FBTrainer(model_cfg, train_cfg, load_dataset(data))


def test_a_stopped_fb_run_saves_its_step_and_resumes_exactly(
    fixture_data: Path, tmp_path: Path
) -> None:
    from fbil.fb.model import FBModel

    straight = _fb_trainer(fixture_data, 12).fit(tmp_path / "straight", progress=False)
    trainer = _fb_trainer(fixture_data, 12)
    trainer.update = _signal_at(lambda: trainer.step, trainer.update, 7, signal.SIGTERM)
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(TrainingStopped, match=r"SIGTERM at step 7; .*--resume") as err:
        trainer.fit(tmp_path / "cut", progress=False)
    assert err.value.exit_code == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) is before  # handlers restored
    # No timed checkpoint was due (checkpoint_seconds 1e9): this one is the stop's.
    assert load_state(tmp_path / "cut" / "checkpoint.safetensors")["step"] == 7
    assert FBModel.load(tmp_path / "cut").metadata["steps"] == 7
    resumed = _fb_trainer(fixture_data, 12).fit(tmp_path / "cut", resume=True, progress=False)
    a, b = straight.state_dict(), resumed.state_dict()
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_a_stopped_goal_pretraining_resumes_exactly(fixture_data: Path, tmp_path: Path) -> None:
    from fbil.baselines.goal_td3 import GoalTD3Trainer, goal_preset

    cfg = dataclasses.replace(
        goal_preset("point_mass_maze", "smoke"), steps=10, log_every=5, checkpoint_seconds=1e9
    )
    dataset = load_dataset(fixture_data)
    whole = GoalTD3Trainer(cfg, dataset).fit(tmp_path / "whole", progress=False)
    trainer = GoalTD3Trainer(cfg, dataset)
    trainer.update = _signal_at(lambda: trainer.step, trainer.update, 4, signal.SIGINT)
    with pytest.raises(TrainingStopped, match="SIGINT at step 4"):
        trainer.fit(tmp_path / "cut", progress=False)
    resumed = GoalTD3Trainer(cfg, dataset).fit(tmp_path / "cut", resume=True, progress=False)
    a, b = whole.tensors(), resumed.tensors()
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_a_stopped_expert_keeps_its_step_and_its_replay_buffer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from fbil.agents import expert
    from fbil.agents.td3 import TD3Config

    calls = {"n": 0}
    step = expert._OnlineLoop.step

    def counted(self: Any) -> Any:
        calls["n"] += 1
        return step(self)

    monkeypatch.setattr(
        expert._OnlineLoop, "step", _signal_at(lambda: calls["n"], counted, 13, signal.SIGINT)
    )
    kw: dict[str, Any] = dict(config=TD3Config(hidden=32, batch_size=16), eval_episodes=1)
    kw |= dict(start_steps=10, checkpoint_seconds=1e9, progress=False)
    out = tmp_path / "online"
    with pytest.raises(TrainingStopped, match="step 13"):
        expert.train_expert("point_mass_maze", "loop", "online", out, steps=40, **kw)
    state = load_state(out / "checkpoint.safetensors")
    assert state["step"] == 13 and len(state["learner"]["rew"]) == 13


def test_a_second_signal_acts_at_once() -> None:
    # Python's own Ctrl-C handler first: a shell's background job (`cmd &`) starts with
    # SIGINT ignored, and the second signal then goes to that ignore, as it should.
    outer = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with StopSignals() as stop:
            signal.raise_signal(signal.SIGINT)
            assert stop and stop.signum == signal.SIGINT
            with pytest.raises(KeyboardInterrupt):  # the handler from before
                signal.raise_signal(signal.SIGINT)
                time.sleep(0.1)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, outer)


def test_ctrl_c_on_the_command_line_says_where_it_stopped(
    fixture_data: Path, tmp_path: Path
) -> None:
    out = tmp_path / "run"
    command = [sys.executable, "-m", "fbil", "pretrain", "point_mass_maze", "--data"]
    command += [str(fixture_data), "--preset", "smoke", "--out", str(out), "--threads", "1"]
    proc = subprocess.Popen([*command, "--steps", "1000000"], stderr=subprocess.PIPE, text=True)
    log = out / "train_log.csv"
    deadline = time.time() + 120
    while time.time() < deadline and len(log.read_text().splitlines() if log.exists() else []) < 3:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    line = err.strip().splitlines()[-1]
    assert line.startswith("fbil: stopped by SIGINT at step ") and "--resume" in line, err
    step = int(line.split("at step ")[1].split(";")[0])
    assert load_state(out / "checkpoint.safetensors")["step"] == step > 0
    done = subprocess.run(
        [*command, "--steps", str(step + 5), "--resume"], capture_output=True, text=True
    )
    assert done.returncode == 0 and f"({step + 5} steps)" in done.stdout, done.stderr
