"""`scripts/z_coverage.py`: unit training directions of the asked counts, and
each method's nearest cosines within [-1, 1]; a one-z-per-step method is refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from fbil.data import load_dataset
from fbil.fb.model import FBModel
from tests.script_module import load_script

DEMOS = Path(__file__).resolve().parents[2] / "artifacts" / "demos" / "point_mass_maze"


def test_directions_are_unit_vectors_of_the_asked_counts(
    smoke_model_dir: Path, fixture_data: Path
) -> None:
    model, data = FBModel.load(smoke_model_dir), load_dataset(fixture_data)
    b, means = load_script("z_coverage").training_directions(model, data, 300, 200)
    assert b.shape == (300, model.config.z_dim) and means.shape == (200, model.config.z_dim)
    for x in (b, means):
        torch.testing.assert_close(x.norm(dim=-1), torch.ones(len(x)))


def test_cli_json_and_errors(
    smoke_model_dir: Path, fixture_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = load_script("z_coverage")
    out = tmp_path / "c.json"
    base = [str(smoke_model_dir), "--data", str(fixture_data), "--demos", str(DEMOS)]
    small = ["--tasks", "loop", "--states", "200", "--segments", "100"]
    assert script.main([*base, *small, "--methods", "erfb,dmfb", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["methods"]
    assert set(rows) == {"erfb", "dmfb"}
    assert all(-1 - 1e-6 <= c <= 1 + 1e-6 for r in rows.values() for v in r.values() for c in v)
    assert script.main([*base, *small, "--methods", "goalfb"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("z_coverage: error:"), err
