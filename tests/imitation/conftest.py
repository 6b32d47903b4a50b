"""Fixtures of the exact tests: the tabular FB model (diagonal and dense B) and float64."""

from collections.abc import Iterator

import pytest
import torch

from tests.imitation.tabular import TabularFB


@pytest.fixture
def float64() -> Iterator[None]:
    """Exact comparisons in double precision, restored afterwards (the exact test modules
    use it for every test, through `pytestmark`)."""
    previous = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    yield
    torch.set_default_dtype(previous)


@pytest.fixture(params=["diagonal", "dense"])
def fb(request: pytest.FixtureRequest) -> TabularFB:
    """The tabular model with B = e_s (diagonal) and with B = Q e_s (dense)."""
    return TabularFB(n_states=6, n_actions=3, gamma=0.8, seed=0, dense=request.param == "dense")
