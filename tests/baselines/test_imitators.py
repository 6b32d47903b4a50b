"""The imitator registry: names, families and groups; side-by-side acting of policies of
different kinds."""

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from fbil.errors import FbilError
from fbil.evaluation import evaluate as evaluate_module
from fbil.evaluation.evaluate import MultiPolicy, fit_all
from fbil.imitation import MAIN_METHODS, METHODS, Demos, from_arrays
from fbil.imitators import FitContext, Imitator, imitators, resolve


def test_every_method_is_registered_once_with_its_family() -> None:
    table = imitators()
    assert [n for n, i in table.items() if i.family == "fb-il"] == list(METHODS)
    assert [n for n, i in table.items() if i.family == "offline-il"] == [
        "bc",
        "td3il",
        "oril",
        "oril_o",
        "oril_oo",
        "dwbc",
        "sqil",
        "demodice",
        "smodice",
        "lobsdice",
        "iqlearn",
        "otr",
    ]
    assert [n for n, i in table.items() if i.family == "bfm"] == ["goal_td3"]
    assert table["goal_td3"].needs_goal_model and not table["goal_td3"].budgets
    assert all(i.principle for i in table.values())
    assert table["bc"].needs_actions and not table["bc"].needs_dataset
    assert table["oril_o"].needs_dataset and not table["oril_o"].needs_actions
    assert all(set(i.budgets) == {"cpu", "smoke"} for i in table.values() if i.budgets)


def test_names_and_groups_resolve() -> None:
    assert resolve("all").names == MAIN_METHODS and resolve("all").group
    assert resolve("offline-il").names[0] == "bc" and resolve("offline-il").group
    explicit = resolve(" BC , erfb")
    assert explicit.names == ["bc", "erfb"] and not explicit.group
    with pytest.raises(FbilError, match="unknown method gail; valid: erfb"):
        resolve("bc,gail")
    assert resolve("bfm").names == ["goal_td3"] and resolve("bfm").group


class Shared:
    """Policies with one `together_key` act in one call."""

    calls: list[int] = []  # noqa: RUF012

    def __init__(self, value: float) -> None:
        self.value, self.together_key = value, "shared"

    @staticmethod
    def act_together(policies: Any, episodes: int, obs: np.ndarray, step: int) -> np.ndarray:
        Shared.calls.append(len(obs))
        return np.repeat([[p.value] for p in policies], episodes, axis=0) + 0 * obs[:, :1]


class Alone:
    def __init__(self, value: float) -> None:
        self.value = value

    def act(self, obs: np.ndarray, step: int | None = None) -> np.ndarray:
        return np.full((len(obs), 1), self.value)


def test_policies_of_different_kinds_play_side_by_side() -> None:
    Shared.calls.clear()
    policies: list[Any] = [Shared(1), Shared(2), Alone(3), Shared(4)]
    actions = MultiPolicy(policies, episodes=2)(np.zeros((8, 4), np.float32), 0)
    assert actions[:, 0].tolist() == [1, 1, 2, 2, 3, 3, 4, 4]
    assert Shared.calls == [4, 2]  # the first two together, the last on its own


def _maze_demos() -> Demos:
    """Two short maze demonstrations with actions, their domain, task and return."""
    rng = np.random.default_rng(0)
    obs = [rng.uniform(-0.2, 0.2, (11, 4)).astype(np.float32) for _ in range(2)]
    acts = [rng.uniform(-1, 1, (10, 2)).astype(np.float32) for _ in range(2)]
    demos = from_arrays(obs, acts)
    meta = {"domain": "point_mass_maze", "task": "square", "return_mean": 10.0}
    return Demos(demos.trajectories, meta)


def test_a_goal_model_of_another_domain_is_refused_before_any_method_trains(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def no_training(self: Imitator, demos: Demos, context: FitContext) -> None:
        raise AssertionError(f"{self.name} was fitted before every input was checked")

    monkeypatch.setattr(Imitator, "fit", no_training)
    walker = SimpleNamespace(domain="walker", config=SimpleNamespace(obs_dim=24, act_dim=6))
    context = FitContext(budget="smoke", goal_model=walker)
    with pytest.raises(FbilError, match="the goal model is for walker"):
        fit_all(["bc", "goal_td3"], _maze_demos(), context, skip_unfit=False)


def test_no_evaluation_episodes_is_refused_before_any_method_trains(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def no_fitting(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("methods were fitted before --episodes was checked")

    monkeypatch.setattr(evaluate_module, "fit_all", no_fitting)
    with pytest.raises(FbilError, match="--episodes must be >= 1, got 0"):
        evaluate_module.evaluate(None, _maze_demos(), "bc", episodes=0, budget="smoke")
