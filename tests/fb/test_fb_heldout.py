"""`scripts/fb_heldout.py`: the diagonal measure term is the model's own F^T B on the sampled
transitions (not a fresh trainer's), the same data on both sides gives r = 1, and mistakes
are one-line errors."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest
import torch

from fbil.data import load_dataset
from fbil.fb.model import FBModel
from fbil.fb.train import FBTrainer
from tests.script_module import load_script


def test_diag_is_the_models_own_measure_on_the_batch(
    smoke_model_dir: Path, fixture_data: Path
) -> None:
    script = load_script("fb_heldout")
    model, data = FBModel.load(smoke_model_dir), load_dataset(fixture_data)
    # Gaussian z's only, so the batch's z is sqrt(d) * normalize(z_gauss), known here.
    cfg = dataclasses.replace(script._train_config(model), z_from_b_ratio=0.0)
    got = script.measure_terms(model, cfg, data, batches=1, seed=3)
    batch = FBTrainer(model.config, dataclasses.replace(cfg, seed=3), data).sample()
    z = math.sqrt(model.config.z_dim) * torch.nn.functional.normalize(batch.z_gauss, dim=-1)
    with torch.no_grad(), torch.autocast("cpu", torch.bfloat16, enabled=cfg.precision == "bf16"):
        f = model.forward_net(batch.obs, z, batch.action).float()  # (2, n, d)
        b = model.backward_net(batch.next_obs).float()
    want = float((f * b).sum(-1).mean())
    assert got["diag"] == pytest.approx(want, rel=1e-4, abs=1e-5)


def test_same_data_gives_r_one_and_the_json(
    smoke_model_dir: Path, fixture_data: Path, tmp_path: Path
) -> None:
    out = tmp_path / "h.json"
    args = [str(smoke_model_dir), "--data", str(fixture_data), "--heldout", str(fixture_data)]
    assert load_script("fb_heldout").main([*args, "--batches", "2", "--json", str(out)]) == 0
    row = json.loads(out.read_text())["rows"][0]
    assert row["r"] == pytest.approx(1.0) and row["train"] == row["heldout"]


@pytest.mark.parametrize("change", ["batches", "heldout"])
def test_mistakes_are_one_line_errors(
    smoke_model_dir: Path,
    fixture_data: Path,
    tmp_path: Path,
    change: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    heldout = str(tmp_path / "nowhere") if change == "heldout" else str(fixture_data)
    batches = "0" if change == "batches" else "1"
    args = [str(smoke_model_dir), "--data", str(fixture_data), "--heldout", heldout]
    out = tmp_path / "h.json"
    assert load_script("fb_heldout").main([*args, "--batches", batches, "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fb_heldout: error:"), err
    assert not out.exists()
