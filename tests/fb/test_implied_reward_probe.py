"""fbil.evaluation.implied (the implied-reward probe): its actor check and value check on
hand-made models whose Q and features are known in closed form, its reward identity on an
exact tabular FB model, and its report section."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from fbil.evaluation import implied as probe
from tests.script_module import load_script


class QuadraticModel:
    """Q(s, a, z) = -|a - target(s)|^2; the actor returns `actor(s)`."""

    def __init__(self, target: torch.Tensor, actor: torch.Tensor) -> None:
        self.target, self.actor = target, actor
        self.config = SimpleNamespace(act_dim=target.shape[1])

    def act(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        return self.actor[: len(obs)]

    def q_value(self, obs: torch.Tensor, z: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        k = len(action) // len(self.target)
        target = self.target.repeat_interleave(k, 0) if k > 1 else self.target
        return -((action - target) ** 2).sum(-1)


def test_an_actor_at_the_argmax_of_q_leaves_no_gap() -> None:
    gen = torch.Generator().manual_seed(1)
    target = torch.rand(50, 3, generator=gen) * 1.6 - 0.8
    model = QuadraticModel(target, actor=target.clone())
    out = probe.actor_check(model, torch.zeros(4), torch.zeros(50, 2), target.clone(), 64)
    assert out["actor_gap"] <= 1e-6 and out["actor_gap_local"] <= 1e-6
    assert out["demo_adv"] == pytest.approx(0.0, abs=1e-6)


def test_an_actor_off_the_argmax_leaves_a_gap_that_the_demo_action_closes() -> None:
    gen = torch.Generator().manual_seed(2)
    target = torch.rand(50, 3, generator=gen) * 1.6 - 0.8
    model = QuadraticModel(target, actor=-target.sign())  # far from the best action
    out = probe.actor_check(model, torch.zeros(4), torch.zeros(50, 2), target.clone(), 64)
    assert out["actor_gap"] > 1.0 and out["actor_gap_local"] > 0.0
    assert out["demo_adv"] >= out["actor_gap"] - 1e-6  # the demo's action is the best one
    no_demo = probe.actor_check(model, torch.zeros(4), torch.zeros(50, 2), None, 64)
    assert "demo_adv" not in no_demo and no_demo["actor_gap"] > 0.5


def test_the_value_check_collects_the_discounted_implied_reward() -> None:
    """B(s) = s and constant states v: r_z = v . w at every step, so the collected value
    from any start is (v . w) (1 - gamma^H) / (1 - gamma); the prediction is Q's mean."""
    gamma, horizon, steps = 0.9, 50, 700
    v = torch.tensor([0.5, -1.0, 2.0])
    w = torch.tensor([1.0, 0.5, 0.25])
    model = SimpleNamespace(
        gamma=gamma,
        backward=lambda obs: obs,
        act=lambda obs, z: torch.zeros(len(obs), 1),
        q_value=lambda obs, z, a: torch.full((len(obs),), 7.0),
    )
    obs = np.broadcast_to(v.numpy(), (2, steps + 1, 3)).copy()
    out = probe.value_check(model, torch.zeros(3), w, obs, horizon)
    expected = float(v @ w) * (1 - gamma**horizon) / (1 - gamma)
    assert out["collected"] == pytest.approx(expected, rel=1e-5)
    assert out["predicted"] == pytest.approx(7.0)
    assert out["starts"] == [0, 100, 200, 300, 400, 500]
    short = probe.value_check(model, torch.zeros(3), w, obs[:, :260], horizon)
    assert short["starts"] == [0, 100, 200]  # only starts with a whole horizon after them


def test_demo_coverage_nearest_distance_is_exact_across_chunks() -> None:
    coverage = load_script("demo_coverage")
    gen = torch.Generator().manual_seed(3)
    points, queries = torch.randn(1000, 5, generator=gen), torch.randn(40, 5, generator=gen)
    exact = torch.cdist(queries, points).min(1).values
    assert torch.allclose(coverage.nearest_distance(queries, points, chunk=97), exact)
    assert torch.allclose(coverage.nearest_distance(points[:7], points), torch.zeros(7))


@pytest.mark.parametrize("dense", [False, True])
def test_f_transpose_z_is_the_value_of_the_implied_reward_in_an_exact_model(dense: bool) -> None:
    """In a finite MDP with an exact FB model, F(s, z)^T z equals the value under pi_z of
    r(s') = B(s')^T C^-1 z, the probe's implied reward; with a non-orthonormal B the plain
    B^T z is another reward."""
    from tests.imitation.tabular import TabularFB

    fb = TabularFB(dense=dense)
    z = fb.project_z(torch.randn(fb.z_dim, generator=torch.Generator().manual_seed(4)))
    eye = torch.eye(fb.S, dtype=torch.float64)
    f_z = fb.forward(eye, z) @ z
    m = fb.successor(fb.policy(z))
    reward = fb.backward(eye) @ probe.implied_reward_weights(fb, z)
    assert torch.allclose(f_z, m @ reward, rtol=1e-9, atol=1e-9)
    plain = fb.backward(eye) @ probe.implied_reward_weights(fb, z, plain=True)
    assert not torch.allclose(f_z, m @ plain, rtol=1e-3)


def _row(ret: float, gap: float, demo_gap: float, roll_gap: float) -> dict:
    check = {"actor_gap": demo_gap, "actor_gap_local": 0.1, "saturated": 0.0, "demo_adv": -0.5}
    erfb = {"return_mean": ret, "gap": gap, "at_demo": check}
    erfb["at_rollout"] = {**check, "actor_gap": roll_gap}
    z_r = {**erfb, "return_mean": 500.0, "gap": 0.0}
    return {"demo_return": 800.0, "ERFB": erfb, "z_r": z_r}


def test_the_reading_names_the_bound_by_the_probes_rules() -> None:
    assert probe.reading(_row(500.0, -3.0, 0.0, 0.0)).startswith("–")  # half the demo's
    assert probe.reading(_row(100.0, -0.2, 2.0, 2.0)) == "the implied reward (B)"
    assert probe.reading(_row(100.0, -3.0, 0.1, 1.2)) == "the actor"
    assert probe.reading(_row(100.0, -3.0, 0.4, -0.5)) == "F"
    assert probe.reading(_row(100.0, -3.0, 0.7, 0.2)) == "F and the actor"


def test_an_implied_reward_json_next_to_the_results_adds_its_table(tmp_path: Path) -> None:
    import json

    from fbil.evaluation.report import write_report
    from tests.evaluation.test_report import _maze_rows, _write

    results = _write(tmp_path / "maze.jsonl", _maze_rows())
    assert "what a demo's z pays" not in write_report(results, tmp_path / "r0").read_text()
    table = {
        "domain": "point_mass_maze",
        "model": "m",
        "tasks": {"loop": _row(90.0, -3.0, 0.1, 0.2)},
    }
    (tmp_path / "implied_reward.json").write_text(json.dumps(table))
    text = write_report(results, tmp_path / "r1").read_text()
    assert "## Reward inference: what a demo's z pays" in text
    assert "| loop | 90.0 (800.0) | -3.00 | 0.10 / 0.20 | -0.50 | 0.00 | F |" in text
    (tmp_path / "implied_reward.json").write_text(json.dumps({**table, "domain": "walker"}))
    assert "what a demo's z pays" not in write_report(results, tmp_path / "r2").read_text()


def test_a_z_without_implied_reward_gets_a_nan_gap_not_a_crash(
    smoke_model_dir: Path, fixture_data: Path
) -> None:
    """A task the data never pays gives z_r = 0: r_z is flat over the data, so its gap is
    undefined (nan) and the probe goes on."""
    from fbil.data import load_dataset
    from fbil.fb.model import FBModel

    model, data = FBModel.load(smoke_model_dir), load_dataset(fixture_data)
    unpaid = [t for t in ("loop", "square", "fast_slow") if not np.any(data.reward(t))]
    if not unpaid:
        pytest.skip("every candidate task is paid somewhere in the fixture")
    demos = Path(__file__).resolve().parents[2] / "artifacts" / "demos" / "point_mass_maze"
    cfg = probe.ProbeSettings(episodes=1, horizon=50, actions=4)
    table = probe.probe_model(model, data, demos, unpaid[:1], cfg)
    row = table["tasks"][unpaid[0]]
    assert np.isnan(row["z_r"]["gap"]) and np.isfinite(row["ERFB"]["gap"])
