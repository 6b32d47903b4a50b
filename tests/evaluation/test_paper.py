"""The paper's numbers in fbil.evaluation.paper agree with each other: every domain mean
score is the mean over the domain's tasks of the per-task return over the expert's, so a
typo in either is caught without reading the paper's tables. Where the paper's tables are
on the machine (../shared/paper_tables.json), every row is checked against them too."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fbil.envs import get_domain
from fbil.evaluation.paper import (
    PAPER_NAMES,
    PAPER_RETURNS,
    PAPER_SCORES,
    PAPER_TIMES,
    PRINCIPLE_CLASSES,
    above_max_return,
    paper_score,
    paper_seconds,
    principle_class,
)
from fbil.imitators import imitators


def test_every_domain_has_returns_and_scores_for_the_same_methods() -> None:
    domains = {"point_mass_maze", "walker", "cheetah", "quadruped"}
    assert set(PAPER_RETURNS) == set(PAPER_SCORES) == domains
    for domain, rows in PAPER_RETURNS.items():
        assert set(rows) == {"expert", *PAPER_SCORES[domain]}, domain


@pytest.mark.parametrize("domain", sorted(PAPER_RETURNS))
def test_per_task_returns_name_the_domains_tasks(domain: str) -> None:
    tasks = set(get_domain(domain).tasks)
    for method, row in PAPER_RETURNS[domain].items():
        assert set(row) == tasks, (domain, method)


@pytest.mark.parametrize("domain", sorted(PAPER_SCORES))
def test_domain_mean_scores_follow_from_the_per_task_returns(domain: str) -> None:
    returns = PAPER_RETURNS[domain]
    expert = returns["expert"]
    wrong = {}
    for method, stated in PAPER_SCORES[domain].items():
        ratios = [returns[method][t] / expert[t] for t in expert]
        mean = 100 * sum(ratios) / len(ratios)
        if abs(mean - stated) > 0.05 + 1e-9:  # the paper's scores have one decimal
            wrong[method] = (stated, round(mean, 2))
    assert not wrong, f"{domain}: stated vs recomputed mean score {wrong}"


PAPER_JSON = Path(__file__).resolve().parents[3] / "shared" / "paper_tables.json"


@pytest.mark.skipif(not PAPER_JSON.is_file(), reason="the paper's tables are not on this machine")
def test_every_algorithm_of_tables_5_to_7_is_copied_exactly() -> None:
    tables = json.loads(PAPER_JSON.read_text())["domains"]
    assert set(tables) == set(PAPER_RETURNS)
    for domain, table in tables.items():
        ours = {PAPER_NAMES[m]: row for m, row in PAPER_RETURNS[domain].items()}
        assert ours == table["returns"], domain  # every algorithm, every task, exactly


def test_the_baselines_and_goal_td3_are_keyed_by_fbil_names() -> None:
    registered = set(imitators())
    for domain in PAPER_RETURNS:
        missing = registered - {"klfb"} - set(PAPER_SCORES[domain])
        assert not missing, (domain, missing)  # klfb: an fbil variant, not in the paper
    assert set(PAPER_TIMES) == set(PAPER_NAMES) - {"expert"} == set(PAPER_SCORES["walker"])


def test_table_8_times_read_as_seconds() -> None:
    assert paper_seconds(PAPER_TIMES["td3il"]) == (7 * 3600 + 3 * 60, False)
    assert paper_seconds(PAPER_TIMES["bcfb"]) == (60, False)
    assert paper_seconds(PAPER_TIMES["erfb"]) == (5, True)  # "<5s": an upper bound
    assert paper_seconds(PAPER_TIMES["iqlearn"]) == (13 * 3600 + 17 * 60, False)


def test_each_registered_principle_falls_in_one_of_the_papers_classes() -> None:
    classes = {c for _, c in PRINCIPLE_CLASSES}
    for name, imitator in imitators().items():
        assert principle_class(imitator.principle) in classes, name
    assert principle_class("Bellman gap (B*)") == "FM/DM"
    assert principle_class("reward (0/1 labels)") == "reward"


def test_only_two_paper_returns_exceed_what_any_policy_can_return() -> None:
    """Every reward here pays at most 1 per step over 1000 steps; the paper's SMODICE and
    LobsDICE figures on reach_bottom_left_long are above that, and no other figure is."""
    found = {d: above_max_return(d) for d in PAPER_RETURNS}
    assert found == {
        "point_mass_maze": {
            "smodice": {"reach_bottom_left_long": 1340.2},
            "lobsdice": {"reach_bottom_left_long": 2048.2},
        },
        "walker": {},
        "cheetah": {},
        "quadruped": {},
    }


def test_the_paper_score_over_some_tasks() -> None:
    tasks = get_domain("point_mass_maze").task_names
    assert paper_score("point_mass_maze", "smodice", tasks) == pytest.approx(42.7, abs=0.05)
    kept = [t for t in tasks if t != "reach_bottom_left_long"]
    returns, expert = (
        PAPER_RETURNS["point_mass_maze"]["smodice"],
        PAPER_RETURNS["point_mass_maze"]["expert"],
    )
    by_hand = 100 * sum(returns[t] / expert[t] for t in kept) / 7
    assert paper_score("point_mass_maze", "smodice", kept) == pytest.approx(by_hand)
    assert 19 < by_hand < 21  # the other seven tasks alone: about 20 %, not 42.7
