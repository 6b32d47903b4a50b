"""FB training on a CUDA device (`fbil pretrain --device cuda`): the same updates as on the
CPU, the bf16 path within the seed spread, and a saved model and checkpoint that load and
resume anywhere. Skipped where torch sees no CUDA device (CI has none); on a GPU machine:
`pytest tests/fb/test_cuda.py`."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from fbil.cli import main
from fbil.data import load_dataset
from fbil.fb.config import preset
from fbil.fb.model import FBModel
from fbil.fb.train import FBTrainer

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")

METRICS = ("fb_loss", "ortho_loss", "actor_q")


def _trainer(data: Path, device: str, precision: str = "fp32", seed: int = 0) -> FBTrainer:
    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    train_cfg = dataclasses.replace(train_cfg, precision=precision, seed=seed)
    return FBTrainer(model_cfg, train_cfg, load_dataset(data), device=device)


def test_fp32_updates_on_cuda_match_the_cpu(fixture_data: Path) -> None:
    """Every random draw comes from the trainer's CPU generator, so both devices see the
    same batches, z and noise: over 10 fp32 updates (TF32 off, PyTorch's default for
    matrix products) every update's losses agree to rounding. Adam moves a weight by up to
    ~lr a step whatever its gradient's size, so rounding in a near-zero gradient can flip
    that step's sign: the weights agree within 2 lr per update (seen on an H200: 4e-4
    after 10 updates at lr 1e-4 on one B bias), and each moved on the GPU when it did on
    the CPU."""
    torch.backends.cuda.matmul.allow_tf32 = False
    cpu, gpu = _trainer(fixture_data, "cpu"), _trainer(fixture_data, "cuda")
    start = [p.detach().cpu().clone() for p in gpu.model.parameters()]
    steps = 10
    for _ in range(steps):
        want, got = cpu.update(), gpu.update()
        for k in METRICS:
            assert float(got[k]) == pytest.approx(float(want[k]), rel=1e-3, abs=1e-4), k
    lr = max(cpu.cfg.lr_f, cpu.cfg.lr_b, cpu.cfg.lr_actor)
    named = zip(cpu.model.named_parameters(), gpu.model.parameters(), start, strict=True)
    for (name, p), q, q0 in named:
        assert q.device.type == "cuda"
        assert (p - q.cpu()).abs().max() <= 2 * lr * steps, name
        assert torch.equal(q.cpu(), q0) == torch.equal(p, q0), name


def _curves(data: Path, precision: str, seed: int, steps: int = 1000) -> dict[str, np.ndarray]:
    trainer = _trainer(data, "cuda", precision, seed)
    rows = [trainer.update() for _ in range(steps)]
    return {k: np.array([float(r[k]) for r in rows]).reshape(8, -1).mean(1) for k in METRICS}


def test_bf16_on_cuda_trains_like_fp32_within_the_seed_spread(fixture_data: Path) -> None:
    """The preset's bf16 autocast on CUDA: per metric, the mean gap between its windowed
    loss curve and fp32's (same seed) is below the gap between two fp32 seeds, the same
    criterion as tests/fb/test_compile.py on the CPU."""
    fp32, other_seed = _curves(fixture_data, "fp32", 0), _curves(fixture_data, "fp32", 1)
    bf16 = _curves(fixture_data, "bf16", 0)
    for k in METRICS:
        assert np.abs(bf16[k] - fp32[k]).mean() < np.abs(other_seed[k] - fp32[k]).mean(), k


def test_pretrain_on_cuda_saves_a_model_that_loads_on_the_cpu_and_resumes(
    fixture_data: Path, tmp_path: Path
) -> None:
    out = tmp_path / "model"
    base = ["pretrain", "point_mass_maze", "--data", str(fixture_data), "--preset", "smoke"]
    base += ["--out", str(out), "--device", "cuda", "--threads", "1"]
    assert main([*base, "--steps", "40"]) == 0
    model = FBModel.load(out)
    assert all(p.device.type == "cpu" for p in model.parameters())
    obs = load_dataset(fixture_data).observation[:50]
    z = model.reward_inference(obs, np.ones(len(obs), np.float32))
    assert z.shape == (model.z_dim,) and torch.isfinite(z).all()
    # The checkpoint (optimisers' state on the GPU) resumes on the GPU to a longer run.
    assert main([*base, "--steps", "60", "--resume"]) == 0
    assert torch.isfinite(torch.cat([p.flatten() for p in FBModel.load(out).parameters()])).all()
