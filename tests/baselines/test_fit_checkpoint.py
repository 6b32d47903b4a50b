"""A baseline's fit killed during training resumes from its checkpoint to the very same
policy (`fbil.checkpoint.FitCheckpoint`), in the training loops and in `fbil benchmark`."""

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from fbil.baselines.common import Transitions
from fbil.baselines.offline_td3 import OfflineTD3Config, train_offline_td3
from fbil.baselines.sac import SAC, SACConfig, train_sac
from fbil.checkpoint import FitCheckpoint, save_state
from fbil.data import load_dataset
from fbil.evaluation.benchmark import make_jobs, run_benchmark, run_job

STEPS, KILL = 30, 12


def _reward(batch: Transitions) -> torch.Tensor:
    return batch.obs[:, 0]  # any fixed function of the row will do


def _sac_update(agent: SAC, batch: Transitions) -> dict[str, float]:
    return agent.update(batch, _reward(batch))


def _train(learner: str, data: Any, checkpoint: FitCheckpoint | None, kill: int = 0) -> Any:
    """The learner's loop at a tiny size; KeyboardInterrupt after update `kill`."""

    def on_step(t: int, agent: Any) -> None:
        if t == kill:
            raise KeyboardInterrupt

    if learner == "td3":
        cfg = OfflineTD3Config(steps=STEPS, hidden=32, batch_size=64)
        agent, info = train_offline_td3(
            data, _reward, cfg, 3, on_step=on_step, checkpoint=checkpoint
        )
        return agent.actor, agent.critics, info
    sac = SACConfig(steps=STEPS, hidden=32, batch_size=64)
    agent, info = train_sac(data, _sac_update, sac, 3, None, 0.0, on_step, checkpoint)
    return agent.actor, agent.critics, {**info, "alpha": float(agent.alpha)}


def _same(a: Any, b: Any) -> bool:
    nets = zip(a[:2], b[:2], strict=True)
    weights = all(
        torch.equal(x, y)
        for m, n in nets
        for x, y in zip(m.state_dict().values(), n.state_dict().values(), strict=True)
    )
    return weights and a[2] == b[2]


@pytest.mark.parametrize("learner", ["td3", "sac"])
def test_a_killed_loop_resumes_to_the_same_weights(
    learner: str, fixture_data: Path, tmp_path: Path
) -> None:
    data = load_dataset(fixture_data)
    whole = _train(learner, data, None)
    path = tmp_path / "fit.safetensors"
    with pytest.raises(KeyboardInterrupt):
        _train(learner, data, FitCheckpoint(path, "job", every=0.0), kill=KILL)
    again = FitCheckpoint(path, "job", every=0.0)  # as a new process would
    resumed = _train(learner, data, again)
    assert again.resumed_at == [KILL]
    assert _same(resumed, whole)
    # A file of another job (another signature) is not resumed: a fresh run, the same one.
    other = FitCheckpoint(path, "another job")
    assert _same(_train(learner, data, other), whole) and other.resumed_at == []


def test_time_to_policy_counts_the_earlier_processes(tmp_path: Path) -> None:
    path = tmp_path / "fit.safetensors"
    entry = {"signature": "job", "phase": "td3", "step": 5, "info": {}, "seconds": 1000.0}
    save_state(path, {**entry, "agent": {"w": torch.zeros(2)}})
    checkpoint = FitCheckpoint(path, "job")
    checkpoint.begin()
    assert checkpoint.resume("sac") is None and checkpoint.seconds() < 1000.0  # other phase
    saved = checkpoint.resume("td3")
    assert saved is not None and saved[0] == 5
    assert 1000.0 <= checkpoint.seconds() < 1010.0 and checkpoint.resumed_at == [5]
    path.write_bytes(b"cut short")  # an unreadable file: start afresh
    assert FitCheckpoint(path, "job").resume("td3") is None


def test_a_benchmark_job_killed_in_training_resumes_to_the_same_line(
    demos_dir: Path,
    fixture_data: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    (job,) = make_jobs(
        None, demos_dir, "point_mass_maze", ["square"], ["td3il"], 1, 1, 2,
        data=fixture_data, budget="smoke",
    )  # fmt: skip
    whole = run_job(job)
    fits = tmp_path / "fits"
    tick = FitCheckpoint.tick

    def killed(self: FitCheckpoint, phase: str, step: int, *args: Any) -> None:
        self.every = 0.0
        tick(self, phase, step, *args)
        if step == KILL:
            raise KeyboardInterrupt

    monkeypatch.setattr(FitCheckpoint, "tick", killed)
    with pytest.raises(KeyboardInterrupt):
        run_job(job, fits=str(fits))
    (left,) = fits.iterdir()
    assert left.name.startswith("td3il_square_d0_s0_")
    monkeypatch.setattr(FitCheckpoint, "tick", tick)
    resumed = run_job(job, fits=str(fits))
    assert resumed["resumed_at"] == [KILL] and "resumed_at" not in whole
    assert np.array_equal(resumed["returns"], whole["returns"])
    assert resumed["seconds"] > 0 and not any(fits.iterdir())  # the job's file is gone


def test_the_benchmark_leaves_no_checkpoint_folder(
    demos_dir: Path, fixture_data: Path, tmp_path: Path
) -> None:
    jobs = make_jobs(
        None, demos_dir, "point_mass_maze", ["square"], ["td3il"], 1, 1, 1,
        data=fixture_data, budget="smoke",
    )  # fmt: skip
    out = tmp_path / "grid.jsonl"
    (row,) = run_benchmark(jobs, out)
    assert "resumed_at" not in row
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grid.jsonl"]
