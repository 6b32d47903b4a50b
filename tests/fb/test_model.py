import dataclasses
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file, save_file

from fbil.data import load_dataset
from fbil.errors import FbilError
from fbil.fb.config import FBModelConfig
from fbil.fb.model import FBModel
from fbil.fb.train import _offdiag_mean_sq, offdiag_residual_sq
from fbil.fb.zero_shot import dataset_backward
from tests.envs.test_registry import EXPECTED


@pytest.fixture(scope="module")
def trained(smoke_model_dir: Path, fixture_data: Path) -> tuple[FBModel, Path, Path]:
    return FBModel.load(smoke_model_dir), smoke_model_dir, fixture_data


@pytest.mark.parametrize("b_norm", ["l2", "batchnorm", "none"])
def test_every_inference_verb_returns_z_of_norm_sqrt_d(b_norm: str) -> None:
    cfg = FBModelConfig(
        obs_dim=4, act_dim=2, z_dim=12, b_hidden=16, f_hidden=16, f_embed=8, b_norm=b_norm
    )  # type: ignore[arg-type]
    model = FBModel(cfg).frozen()
    obs = torch.randn(32, 4)
    for z in (
        model.reward_inference(obs, torch.rand(32)),
        model.goal_inference(obs),
        model.project_z(torch.randn(5, 12)),
        model.sample_z(7),
    ):
        torch.testing.assert_close(z.norm(dim=-1), torch.full(z.shape[:-1], math.sqrt(12)))
    # One z for many states broadcasts, in `forward` as in `act`.
    z = model.sample_z(1)[0]
    torch.testing.assert_close(model.forward(obs, z), model.forward(obs, z.expand(32, -1)))


def test_cov_b_is_the_empirical_second_moment_of_b(trained: tuple[FBModel, Path, Path]) -> None:
    model, _, data = trained
    b = dataset_backward(model, load_dataset(data)).double()
    torch.testing.assert_close(model.cov_b.double(), b.T @ b / len(b), rtol=1e-5, atol=1e-5)


def test_save_load_round_trip_gives_identical_outputs(
    trained: tuple[FBModel, Path, Path], tmp_path: Path
) -> None:
    model, _, _ = trained
    model.save(tmp_path / "again")
    back = FBModel.load(tmp_path / "again")
    obs, z = torch.randn(9, 4), model.sample_z(9)
    for fn in (
        lambda m: m.backward(obs),
        lambda m: m.forward(obs, z, heads="both"),
        lambda m: m.act(obs, z),
    ):
        torch.testing.assert_close(fn(model), fn(back), rtol=0, atol=0)
    assert not back.training and not any(p.requires_grad for p in back.parameters())
    # z can still be optimised through the frozen networks (what FB-IL does).
    zz = model.sample_z(1).requires_grad_(True)
    (back.forward(obs[:1], zz) ** 2).sum().backward()
    assert zz.grad is not None and torch.all(torch.isfinite(zz.grad))


def test_damaged_checkpoints_are_refused_by_name(
    trained: tuple[FBModel, Path, Path], tmp_path: Path
) -> None:
    _, directory, _ = trained
    for damage in ("missing", "shape", "garbage"):
        bad = tmp_path / damage
        shutil.copytree(directory, bad)
        weights = load_file(str(bad / "model.safetensors"))
        if damage == "missing":
            weights.pop(next(iter(weights)))
            save_file(weights, str(bad / "model.safetensors"))
        elif damage == "shape":
            key = next(k for k in weights if k.endswith("weight"))
            weights[key] = torch.zeros(3, 3)
            save_file(weights, str(bad / "model.safetensors"))
        else:
            (bad / "model.safetensors").write_bytes(b"\x00" * 64)
        with pytest.raises(FbilError, match=r"model\.safetensors"):
            FBModel.load(bad)
    with pytest.raises(FbilError, match="no FB model"):
        FBModel.load(tmp_path / "nowhere")


def test_offdiagonal_mean_needs_no_mask() -> None:
    x = torch.randn(3, 6, 6)
    mask = ~torch.eye(6, dtype=torch.bool)
    expected = torch.stack([xi[mask].pow(2).mean() for xi in x])
    torch.testing.assert_close(_offdiag_mean_sq(x), expected)


def test_low_rank_fb_residual_matches_the_n_by_n_form() -> None:
    # The FB loss's off-diagonal term and its gradients, without forming F B^T, against
    # the masked n x n residual, in float64 (exact up to rounding).
    gen = torch.Generator().manual_seed(0)
    f0 = torch.randn(2, 7, 3, generator=gen, dtype=torch.float64)
    b0 = torch.randn(7, 3, generator=gen, dtype=torch.float64)
    target = torch.randn(7, 7, generator=gen, dtype=torch.float64)
    mask = ~torch.eye(7, dtype=torch.bool)
    results = []
    for low_rank in (True, False):
        f, b = f0.clone().requires_grad_(True), b0.clone().requires_grad_(True)
        if low_rank:
            value = offdiag_residual_sq(f, b, target)
        else:
            value = torch.stack([(fk @ b.T - target)[mask].pow(2).mean() for fk in f])
        (value * torch.tensor([1.0, 3.0], dtype=torch.float64)).sum().backward()
        results.append((value.detach(), f.grad, b.grad))
    for got, want in zip(*results, strict=True):
        torch.testing.assert_close(got, want, rtol=1e-10, atol=1e-10)


def _zero_shot_cli(directory: Path, data: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "fbil", "zero-shot", str(directory), "--data", str(data)]
    return subprocess.run(
        [*cmd, "--episodes", "2", "--json", *extra], capture_output=True, text=True, timeout=300
    )


def test_zero_shot_cli_reports_every_maze_task(
    trained: tuple[FBModel, Path, Path],
) -> None:
    _, directory, data = trained
    res = _zero_shot_cli(directory, data)
    assert res.returncode == 0, res.stderr
    tasks = json.loads(res.stdout)["tasks"]
    assert list(tasks) == EXPECTED["point_mass_maze"][2]
    assert all(t["episodes"] == 2 and math.isfinite(t["return_mean"]) for t in tasks.values())
    # A comma list runs those tasks, in that order, with the same returns as `all`.
    some = _zero_shot_cli(directory, data, "--tasks", "square,reach_top_left")
    assert some.returncode == 0, some.stderr
    assert json.loads(some.stdout)["tasks"] == {t: tasks[t] for t in ("square", "reach_top_left")}
    bad = _zero_shot_cli(directory, data, "--tasks", "square,reach_middle")
    assert bad.returncode == 2 and "unknown task 'reach_middle'" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1


def test_zero_shot_refuses_a_dataset_of_another_domain(
    trained: tuple[FBModel, Path, Path], tmp_path: Path
) -> None:
    from fbil.fb.config import preset

    _, _, maze_data = trained
    for metadata in ({"dataset_manifest": {"domain": "walker"}}, {}):  # recorded, or by size
        FBModel(preset("walker", "smoke")[0], metadata=metadata).save(tmp_path / "walker")
        res = _zero_shot_cli(tmp_path / "walker", maze_data)
        assert res.returncode == 2, res.stderr
        assert "the model is for" in res.stderr and "point_mass_maze" in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1


def test_standardised_inputs_use_the_data_statistics_and_survive_save_load(
    fixture_data: Path, tmp_path: Path
) -> None:
    cfg = FBModelConfig(
        obs_dim=4, act_dim=2, z_dim=8, b_hidden=16, f_hidden=16, f_embed=8, normalize_obs=True
    )
    model = FBModel(cfg)
    obs = load_dataset(fixture_data).observation
    model.set_obs_stats(obs)
    model.save(tmp_path / "m")
    back = FBModel.load(tmp_path / "m")
    for net in (back.backward_net, back.forward_net, back.actor):
        stats = net.obs_norm.obs_stats.double()
        torch.testing.assert_close(stats[0], torch.from_numpy(obs).double().mean(0))
        torch.testing.assert_close(stats[1], torch.from_numpy(obs).double().std(0).clamp_min(1e-3))
    # Shifting the data by a constant and the statistics with it changes no output.
    x, z = torch.from_numpy(obs[:5]), back.sample_z(5)
    shifted = FBModel(cfg)
    shifted.load_state_dict(back.state_dict())
    shifted.set_obs_stats(obs + 1.0)
    torch.testing.assert_close(shifted.backward(x + 1.0), back.backward(x), rtol=1e-4, atol=1e-4)
    torch.testing.assert_close(shifted.act(x + 1.0, z), back.act(x, z), rtol=1e-4, atol=1e-4)


def test_a_model_without_a_recorded_discount_is_refused_by_imitation() -> None:
    from fbil.errors import FbilError
    from fbil.fb.config import preset
    from fbil.fb.model import FBModel

    model = FBModel(preset("point_mass_maze", "smoke")[0])
    with pytest.raises(FbilError, match="records no training discount"):
        _ = model.gamma
    assert FBModel(model.config, {"train_config": {"gamma": 0.97}}).gamma == 0.97


def test_independent_f_heads_share_no_parameter_and_survive_save_load(tmp_path: Path) -> None:
    """f_heads="independent": each head's output depends on its own embeddings only (the
    gradient of head 1 leaves head 0's untouched, and vice versa), the heads differ, and
    the saved model loads back to the same outputs; "shared" keeps the old parameter names."""
    cfg = FBModelConfig(obs_dim=4, act_dim=2, z_dim=6, b_hidden=8, f_hidden=8, f_embed=4)
    shared = FBModel(cfg)
    assert hasattr(shared.forward_net, "sa") and not hasattr(shared.forward_net, "sa_heads")
    model = FBModel(dataclasses.replace(cfg, f_heads="independent"))
    f = model.forward_net
    obs, z, act = torch.randn(5, 4), torch.randn(5, 6), torch.rand(5, 2)
    out = f(obs, z, act)
    assert out.shape == (2, 5, 6) and not torch.allclose(out[0], out[1])
    for k in (0, 1):
        f.zero_grad()
        out = f(obs, z, act)
        out[k].sum().backward()
        for emb in (f.sa_heads, f.sz_heads):
            assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in emb[k].parameters())
            assert all(p.grad is None or p.grad.abs().sum() == 0 for p in emb[1 - k].parameters())
    model.save(tmp_path / "indep")
    back = FBModel.load(tmp_path / "indep")
    assert back.config.f_heads == "independent"
    torch.testing.assert_close(
        back.forward(obs, z, act, heads="both"), model.forward(obs, z, act, heads="both")
    )
    with pytest.raises(FbilError, match="unknown f_heads 'triple'; valid: shared, independent"):
        FBModelConfig(obs_dim=4, act_dim=2, f_heads="triple")  # type: ignore[arg-type]
