"""`scripts/fb_diagnostics.py`: its numbers against direct recomputation on a smoke model,
and the CLI's JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from fbil.data import load_dataset
from fbil.fb.model import FBModel
from tests.script_module import load_script

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "fb_diagnostics.py"


def _module():  # type: ignore[no-untyped-def]
    return load_script("fb_diagnostics")


def test_reference_mass_and_reward_fit(smoke_model_dir: Path, fixture_data: Path) -> None:
    model, data = FBModel.load(smoke_model_dir), load_dataset(fixture_data)
    res = _module().diagnostics(model, data, states=500)
    # Recompute the reference mass and one task's R^2 from the same states.
    idx = np.random.default_rng(0).choice(len(data.next_index), 500, replace=False)
    with torch.no_grad():
        b = model.backward(data.observation[data.next_index[idx]]).double()
    cov = b.T @ b / len(b)
    share = float(b.mean(0) @ torch.linalg.solve(cov, b.mean(0)))
    assert 0.0 <= share <= 1.0 + 1e-9  # a projection of the constant 1: at most its norm
    assert res["unbiased_mass"] == pytest.approx(share / (1 - model.gamma))
    task = max(res["tasks"], key=lambda t: float(np.var(data.reward(t)[idx])))
    r = torch.from_numpy(data.reward(task)[idx]).double()
    assert r.var() > 0
    fit = b @ torch.linalg.lstsq(b, r[:, None]).solution[:, 0]  # least squares on B
    r2 = 1 - float(((r - fit) ** 2).mean() / r.var())
    assert res["tasks"][task]["reward_r2"] == pytest.approx(r2, abs=1e-6)
    assert 0.0 <= res["saturated_actions"] <= 1.0
    assert 0.0 <= res["actor_beats_best_of_8_random"] <= 1.0


def test_cli_json(smoke_model_dir: Path, fixture_data: Path) -> None:
    out = subprocess.run(
        [sys.executable, str(SCRIPT), str(smoke_model_dir), "--data", str(fixture_data),
         "--states", "300", "--json"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    assert set(res["tasks"]) >= {"loop", "reach_top_left"}
    assert res["states"] == 300
