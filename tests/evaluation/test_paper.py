"""The paper's numbers in fbil.evaluation.paper agree with each other: every domain mean
score is the mean over the domain's tasks of the per-task return over the expert's, so a
typo in either is caught without reading the paper's tables."""

from __future__ import annotations

import pytest

from fbil.envs import get_domain
from fbil.evaluation.paper import PAPER_RETURNS, PAPER_SCORES


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
