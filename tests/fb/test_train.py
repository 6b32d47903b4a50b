"""Exact resumption: N steps straight == N/2, SIGKILL, resume, N/2."""

import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

FIXTURE = Path(__file__).parents[1] / "fixtures" / "exorl" / "point_mass_maze" / "rnd"


def _pretrain(data: Path, out: Path, steps: int, *extra: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "fbil",
        "pretrain",
        "point_mass_maze",
        "--data",
        str(data),
        "--preset",
        "smoke",
        "--out",
        str(out),
        "--steps",
        str(steps),
        "--threads",
        "1",
        "--json",
        *extra,
    ]


def test_kill_and_resume_reproduces_straight_training(tmp_path: Path) -> None:
    data = tmp_path / "data"
    shutil.copytree(FIXTURE, data)
    steps = 400
    straight = subprocess.run(
        _pretrain(data, tmp_path / "straight", steps), capture_output=True, text=True, timeout=600
    )
    assert straight.returncode == 0, straight.stderr
    out = tmp_path / "killed"
    proc = subprocess.Popen(
        _pretrain(data, out, steps, "--checkpoint-seconds", "0"),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    log = out / "train_log.csv"
    deadline = time.time() + 300
    while time.time() < deadline:
        lines = log.read_text().splitlines() if log.exists() else []
        if len(lines) > 1 and int(lines[-1].split(",")[0]) >= steps // 2:
            break
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    # It really died mid-run: the last snapshot of the model is from before the end.
    assert json.loads((out / "config.json").read_text())["steps"] < steps
    resumed = subprocess.run(
        _pretrain(data, out, steps, "--resume"), capture_output=True, text=True, timeout=600
    )
    assert resumed.returncode == 0, resumed.stderr
    a = load_file(str(tmp_path / "straight" / "model.safetensors"))
    b = load_file(str(out / "model.safetensors"))
    assert a.keys() == b.keys()
    for key in a:
        torch.testing.assert_close(a[key], b[key], rtol=1e-6, atol=1e-7, msg=key)
    steps_logged = [int(r.split(",")[0]) for r in (out / "train_log.csv").read_text().split()[1:]]
    assert steps_logged == sorted(set(steps_logged)) and steps_logged[-1] == steps


def test_nstep_target_samples_within_episodes_and_trains(fixture_data: Path) -> None:
    import dataclasses

    from fbil.data import load_dataset
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    data = load_dataset(fixture_data)
    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    trainer = FBTrainer(model_cfg, dataclasses.replace(train_cfg, nstep=4), data)
    rows = trainer.nstep_rows
    first, last = trainer.next_index[rows], trainer.next_index[rows + 3]
    ends = torch.from_numpy(data.state_episode_end)
    assert torch.all(last == first + 3) and torch.all(last <= ends[first])
    torch.testing.assert_close(trainer.k_probs.sum(), torch.tensor(1.0))
    for _ in range(5):
        out = trainer.update()
    assert all(torch.isfinite(v) for v in out.values())


def test_snapshots_are_usable_models_of_their_step(fixture_data: Path, tmp_path: Path) -> None:
    """snapshot_every=N keeps snapshots/step_N/, each a loadable model of that step."""
    import dataclasses

    from fbil.data import load_dataset
    from fbil.fb.config import preset
    from fbil.fb.model import FBModel
    from fbil.fb.train import FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    cfg = dataclasses.replace(train_cfg, steps=30, snapshot_every=10)
    FBTrainer(model_cfg, cfg, load_dataset(fixture_data)).fit(tmp_path, progress=False)
    snaps = sorted(p.name for p in (tmp_path / "snapshots").iterdir())
    assert snaps == ["step_0000010", "step_0000020", "step_0000030"]
    first, last = (FBModel.load(tmp_path / "snapshots" / s) for s in (snaps[0], snaps[-1]))
    assert first.metadata["steps"] == 10 and last.metadata["steps"] == 30
    final = FBModel.load(tmp_path)
    obs = torch.randn(5, 4)
    torch.testing.assert_close(last.backward(obs), final.backward(obs), rtol=0, atol=0)
    assert not torch.equal(first.backward(obs), final.backward(obs))


def _smoke_trainer(fixture_data: Path, **train: object):  # type: ignore[no-untyped-def]
    import dataclasses

    from fbil.data import load_dataset
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    return FBTrainer(model_cfg, dataclasses.replace(train_cfg, **train), load_dataset(fixture_data))


def test_min_and_mean_targets_agree_exactly_when_the_heads_agree(fixture_data: Path) -> None:
    """target_heads picks how the two target heads combine: equal heads, equal updates;
    different heads, different updates (so the switch is wired into the loss)."""

    def one_update(heads: str, same_heads: bool) -> torch.Tensor:
        trainer = _smoke_trainer(fixture_data, target_heads=heads)
        if same_heads:
            with torch.no_grad():
                for w in [*trainer.f_target.heads.weights, *trainer.f_target.heads.biases]:
                    w[1].copy_(w[0])
        trainer.update()
        return torch.cat([p.flatten() for p in trainer.model.forward_net.parameters()])

    torch.testing.assert_close(one_update("min", True), one_update("mean", True))
    assert not torch.equal(one_update("min", False), one_update("mean", False))


def test_straight_through_clamp_keeps_the_actor_gradient_of_saturated_actions(
    fixture_data: Path,
) -> None:
    """With every noisy action outside [-1, 1], the hard clamp leaves the actor no gradient;
    the straight-through clamp gives the same loss value and a gradient."""
    grads, losses = {}, {}
    for clamp in ("hard", "straight_through"):
        trainer = _smoke_trainer(fixture_data, actor_clamp=clamp, precision="fp32")
        batch = trainer.sample()
        z = trainer.model.sample_z(len(batch.obs), torch.Generator().manual_seed(0))
        noise = torch.full_like(batch.noise[1], 3.0)  # mu + noise > 1 everywhere
        loss, _ = trainer.actor_loss(batch.obs, z, noise)
        loss.backward()
        grads[clamp] = torch.cat([p.grad.flatten() for p in trainer.model.actor.parameters()])
        losses[clamp] = loss.detach()
    torch.testing.assert_close(losses["hard"], losses["straight_through"])
    assert torch.count_nonzero(grads["hard"]) == 0
    assert grads["straight_through"].abs().sum() > 0


def test_q_loss_is_the_td_error_of_f_z_with_the_implicit_reward(fixture_data: Path) -> None:
    """The logged q_loss equals the formula recomputed from the same batch (1-step)."""
    trainer = _smoke_trainer(fixture_data, q_loss_coef=0.5, precision="fp32")
    seen: dict[str, torch.Tensor] = {}
    m = trainer.model
    calls = {"f": 0}
    f_forward, b_forward = m.forward_net.forward, m.backward_net.forward

    def spy_f(obs, z, action):  # type: ignore[no-untyped-def]
        out = f_forward(obs, z, action)
        if calls["f"] == 0:  # the first call is F(s, a, z) of the FB loss
            seen.update(f=out.detach(), z=z.detach())
        calls["f"] += 1
        return out

    def spy_b(obs):  # type: ignore[no-untyped-def]
        out = b_forward(obs)
        seen.setdefault("b", out.detach())
        return out

    t_forward = trainer.f_target.forward

    def spy_t(obs, z, action):  # type: ignore[no-untyped-def]
        out = t_forward(obs, z, action)
        seen["f_tgt"] = out.detach()
        return out

    m.forward_net.forward, m.backward_net.forward = spy_f, spy_b  # type: ignore[method-assign]
    trainer.f_target.forward = spy_t  # type: ignore[method-assign]
    got = trainer.update()["q_loss"]
    b, z, f, f_tgt = seen["b"].double(), seen["z"].double(), seen["f"].double(), seen["f_tgt"]
    reward = (b @ torch.linalg.inv(b.T @ b / len(b)) * z).sum(-1)
    y = reward + trainer.cfg.gamma * (f_tgt.double() * z).sum(-1).min(0).values
    expected = 0.5 * ((f * z).sum(-1) - y).pow(2).mean(-1).sum()
    torch.testing.assert_close(got.double(), expected, rtol=1e-3, atol=1e-3)
    assert got > 0


def test_freeze_b_step_stops_b_and_its_statistics_while_f_learns(fixture_data: Path) -> None:
    """Before freeze_b_step B learns; from it on B's weights and batch-norm statistics stay
    exactly as they were, F and the actor keep learning, and the model stays usable."""
    trainer = _smoke_trainer(fixture_data, freeze_b_step=3)
    m = trainer.model
    assert m.config.b_norm == "batchnorm"  # so the statistics are part of what must stay

    def b_state() -> list[torch.Tensor]:
        return [t.detach().clone() for t in m.backward_net.state_dict().values()]

    def flat(net: torch.nn.Module) -> torch.Tensor:
        return torch.cat([p.detach().flatten() for p in net.parameters()])

    before = b_state()
    for _ in range(3):
        trainer.update()
    at_freeze, f_at_freeze, actor_at_freeze = b_state(), flat(m.forward_net), flat(m.actor)
    assert any(not torch.equal(a, b) for a, b in zip(before, at_freeze, strict=True))
    for _ in range(3):
        metrics = trainer.update()
    for a, b in zip(at_freeze, b_state(), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    assert not torch.equal(f_at_freeze, flat(m.forward_net))
    assert not torch.equal(actor_at_freeze, flat(m.actor))
    assert all(torch.isfinite(v).all() for v in metrics.values())


def test_resume_applies_the_configs_learning_rates(fixture_data: Path, tmp_path: Path) -> None:
    """A checkpoint's Adam state carries the old rates; resuming with new ones uses them."""
    _smoke_trainer(fixture_data, steps=10).fit(tmp_path, progress=False)
    resumed = _smoke_trainer(fixture_data, steps=12, lr_f=3e-3, lr_b=2e-3, lr_actor=1e-3)
    resumed.fit(tmp_path, resume=True, progress=False)
    assert resumed.step == 12
    assert [g["lr"] for g in resumed.opt_fb.param_groups] == [3e-3, 2e-3]
    assert [g["lr"] for g in resumed.opt_actor.param_groups] == [1e-3]


def test_resume_on_other_data_is_noted_and_kept_in_the_metadata(
    fixture_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Fine-tuning = resuming on another dataset: allowed, said once, recorded in order."""
    from fbil.fb.model import FBModel

    other = tmp_path / "other"
    shutil.copytree(fixture_data, other)
    out = tmp_path / "run"
    _smoke_trainer(fixture_data, steps=6).fit(out, progress=False)
    _smoke_trainer(fixture_data, steps=8).fit(out, resume=True, progress=False)
    assert "note: resuming" not in capsys.readouterr().err  # same data: silent
    assert FBModel.load(out).metadata["dataset_history"] == [
        {"dataset": str(fixture_data), "from_step": 0}
    ]
    _smoke_trainer(other, steps=10).fit(out, resume=True, progress=False)
    err = capsys.readouterr().err
    assert err.count("note: resuming at step 8") == 1 and str(fixture_data) in err
    meta = FBModel.load(out).metadata
    assert meta["dataset"] == str(other)
    assert meta["dataset_history"] == [
        {"dataset": str(fixture_data), "from_step": 0},
        {"dataset": str(other), "from_step": 8},
    ]


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("target_heads", "max", "unknown target_heads 'max'; valid: min, mean"),
        ("actor_clamp", "soft", "unknown actor_clamp 'soft'; valid: hard, straight_through"),
        ("precision", "fp16", "unknown precision 'fp16'; valid: fp32, bf16"),
        ("init", "xavier", "unknown init 'xavier'; valid: torch, orthogonal"),
    ],
)
def test_train_config_names_a_bad_choice_and_the_valid_ones(
    field: str, value: str, message: str
) -> None:
    from fbil.errors import FbilError
    from fbil.fb.config import FBTrainConfig

    with pytest.raises(FbilError, match=re.escape(message)):
        FBTrainConfig(**{field: value})  # type: ignore[arg-type]


def test_mean_of_b_rows_are_subset_means_and_other_rows_unchanged(fixture_data: Path) -> None:
    """z_from_b_mean_ratio: the chosen rows' z is the projected mean of B over a non-empty
    subset of the batch's next states; with the ratio at 0 the draws (and so every other
    run) stay exactly as before."""
    trainer = _smoke_trainer(fixture_data, z_from_b_mean_ratio=0.3, precision="fp32")
    batch = trainer.sample()
    assert batch.use_mean is not None and batch.mean_weights is not None
    assert bool(batch.use_mean.any()) and not bool((batch.use_mean & batch.use_b).any())
    w = batch.mean_weights
    torch.testing.assert_close(w.sum(1), torch.ones(len(w)))
    assert int((w > 0).sum(1).min()) >= 1
    with torch.no_grad():
        out = trainer.fb_losses(batch, frozen=False)
        b_next = trainer.model.backward_net(batch.next_obs)
    rows = batch.use_mean
    expected = trainer.model.project_z((w @ b_next)[rows])
    torch.testing.assert_close(out["z"][rows], expected)
    plain, zero = (
        _smoke_trainer(fixture_data),
        _smoke_trainer(fixture_data, z_from_b_mean_ratio=0.0),
    )
    a, b = plain.sample(), zero.sample()
    assert b.use_mean is None and torch.equal(a.use_b, b.use_b) and torch.equal(a.obs, b.obs)


def test_trajectory_rows_are_means_of_b_over_one_episode_segment(fixture_data: Path) -> None:
    """z_from_traj_ratio: the chosen rows' z is the projected mean of B over states of one
    episode (never across an episode's end); with the ratio at 0 every draw stays as before;
    with batch-norm B, the extra pass uses and keeps the running statistics."""
    import copy
    import dataclasses

    from fbil.data import load_dataset
    from fbil.fb.config import preset
    from fbil.fb.train import TRAJ_Z_STATES, FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    data = load_dataset(fixture_data)
    l2 = dataclasses.replace(model_cfg, b_norm="l2")
    cfg = dataclasses.replace(train_cfg, z_from_traj_ratio=0.4, precision="fp32")
    trainer = FBTrainer(l2, cfg, data)
    batch = trainer.sample()
    assert batch.use_traj is not None and batch.traj_obs is not None
    assert batch.traj_obs.shape == (cfg.batch_size, TRAJ_Z_STATES, model_cfg.obs_dim)
    rows = batch.use_traj
    assert bool(rows.any()) and not bool((rows & batch.use_b).any())
    # Every row's states come from one episode: map each observation back to its episode.
    obs = torch.from_numpy(data.observation)
    nxt = torch.from_numpy(data.next_index)
    episode_of_obs = torch.full((len(obs),), -1)
    starts = torch.cat([torch.tensor([0]), torch.nonzero(nxt[1:] != nxt[:-1] + 1).flatten() + 1])
    for e, s0 in enumerate(starts.tolist()):
        end = starts[e + 1].item() if e + 1 < len(starts) else len(nxt)
        episode_of_obs[nxt[s0:end]] = e
    for row in batch.traj_obs:
        idx = [int(torch.nonzero((obs == o).all(1))[0]) for o in row]
        assert len({int(episode_of_obs[i]) for i in idx}) == 1
    with torch.no_grad():
        out = trainer.fb_losses(batch, frozen=False)
        b_traj = trainer.model.backward_net(batch.traj_obs.reshape(-1, model_cfg.obs_dim))
    expected = trainer.model.project_z(b_traj.reshape(cfg.batch_size, TRAJ_Z_STATES, -1).mean(1))
    torch.testing.assert_close(out["z"][rows], expected[rows])
    a = FBTrainer(l2, dataclasses.replace(train_cfg, precision="fp32"), data).sample()
    b = FBTrainer(l2, dataclasses.replace(cfg, z_from_traj_ratio=0.0), data).sample()
    assert b.use_traj is None and torch.equal(a.use_b, b.use_b) and torch.equal(a.obs, b.obs)
    bn = FBTrainer(model_cfg, cfg, data)
    batch, net = bn.sample(), bn.model.backward_net
    start = copy.deepcopy(net.state_dict())
    with torch.no_grad():
        out = bn.fb_losses(batch, frozen=False)
        after = copy.deepcopy(net.state_dict())
        net.load_state_dict(start)
        net(batch.next_obs)  # the loss's own train-mode pass alone moves the statistics
        assert all(torch.equal(after[k], v) for k, v in net.state_dict().items())
        net.eval()
        b_eval = net(batch.traj_obs.reshape(-1, model_cfg.obs_dim))
    rows = batch.use_traj
    assert rows is not None and net.training is False
    mean = b_eval.reshape(cfg.batch_size, TRAJ_Z_STATES, -1).mean(1)
    torch.testing.assert_close(out["z"][rows], bn.model.project_z(mean)[rows])


def test_z_source_ratios_must_be_a_distribution() -> None:
    from fbil.errors import FbilError
    from fbil.fb.config import FBTrainConfig

    with pytest.raises(FbilError, match="sum to <= 1"):
        FBTrainConfig(z_from_b_ratio=0.6, z_from_b_mean_ratio=0.5)
    with pytest.raises(FbilError, match="sum to <= 1"):
        FBTrainConfig(z_from_b_ratio=0.5, z_from_traj_ratio=0.6)


def test_ema_is_the_polyak_average_and_the_saved_model(fixture_data: Path, tmp_path: Path) -> None:
    """ema_decay > 0: the average moves by (1 - decay_t) toward the trained weights each
    update, the trained path is unchanged by it, and the saved model is the average."""
    from fbil.fb.model import FBModel

    plain = _smoke_trainer(fixture_data, steps=3)
    avg = _smoke_trainer(fixture_data, steps=3, ema_decay=0.5)
    before = {k: v.clone() for k, v in avg.ema.actor.state_dict().items()}
    plain.update()
    avg.update()
    for key, value in plain.model.state_dict().items():  # the average leaves training alone
        torch.testing.assert_close(avg.model.state_dict()[key], value, rtol=0, atol=0)
    rate = 1 - min(0.5, 1 / 10)  # first update: decay_0 = (1 + 0) / (10 + 0)
    for key, old in before.items():
        want = old + rate * (avg.model.actor.state_dict()[key] - old)
        torch.testing.assert_close(avg.ema.actor.state_dict()[key], want)
    avg.fit(tmp_path / "run", progress=False)
    saved = FBModel.load(tmp_path / "run")
    obs = torch.randn(5, 4)
    torch.testing.assert_close(saved.backward(obs), avg.ema.backward(obs))
    assert not torch.allclose(saved.backward(obs), avg.model.backward(obs))
    assert saved.metadata["ema_decay"] == 0.5


def test_ema_snapshots_keep_the_trained_weights_beside_the_average(
    fixture_data: Path, tmp_path: Path
) -> None:
    from fbil.fb.model import FBModel

    trainer = _smoke_trainer(fixture_data, steps=20, snapshot_every=10, ema_decay=0.9)
    trainer.fit(tmp_path, progress=False)
    obs = torch.randn(5, 4)
    for step in ("0000010", "0000020"):
        assert (tmp_path / "snapshots" / f"step_{step}" / "model.safetensors").is_file()
        raw = FBModel.load(tmp_path / "raw" / "snapshots" / f"step_{step}")
        assert "ema_decay" not in raw.metadata
    raw_last = FBModel.load(tmp_path / "raw" / "snapshots" / "step_0000020")
    torch.testing.assert_close(raw_last.backward(obs), trainer.model.eval().backward(obs))


def test_ema_survives_a_resume_exactly(fixture_data: Path, tmp_path: Path) -> None:
    from fbil.checkpoint import load_state, save_state

    straight = _smoke_trainer(fixture_data, steps=6, ema_decay=0.8)
    for _ in range(6):
        straight.update()
    first = _smoke_trainer(fixture_data, steps=6, ema_decay=0.8)
    for _ in range(3):
        first.update()
    save_state(tmp_path / "ckpt.safetensors", first.state())
    second = _smoke_trainer(fixture_data, steps=6, ema_decay=0.8)
    second.load(load_state(tmp_path / "ckpt.safetensors"))
    for _ in range(3):
        second.update()
    for key, value in straight.ema.state_dict().items():
        torch.testing.assert_close(second.ema.state_dict()[key], value, rtol=1e-6, atol=1e-7)


def test_the_average_leaves_the_trained_weights_unchanged_to_the_bit(
    fixture_data: Path, tmp_path: Path
) -> None:
    """ema_decay on, from the start or from a resume, draws no random numbers and touches
    neither weights nor optimisers: the trained weights equal a run without it, exactly
    (what lets a recipe's run carry the average as a free paired check)."""
    from fbil.checkpoint import load_state, save_state

    plain = _smoke_trainer(fixture_data, steps=6)
    averaged = _smoke_trainer(fixture_data, steps=6, ema_decay=0.9)
    half = _smoke_trainer(fixture_data, steps=6)
    for _ in range(3):
        half.update()
    save_state(tmp_path / "ckpt.safetensors", half.state())
    resumed = _smoke_trainer(fixture_data, steps=6, ema_decay=0.9)  # the average from here
    resumed.load(load_state(tmp_path / "ckpt.safetensors"))
    for _ in range(6):
        plain.update()
        averaged.update()
    for _ in range(3):
        resumed.update()
    want = plain.model.state_dict()
    for other in (averaged, resumed):
        got = other.model.state_dict()
        assert all(torch.equal(got[k], v) for k, v in want.items())
        assert torch.equal(other.gen.get_state(), plain.gen.get_state())
    assert not all(torch.equal(averaged.ema.state_dict()[k], v) for k, v in want.items())


@pytest.mark.parametrize("decay", [-0.1, 1.0])
def test_ema_decay_outside_its_range_is_named(decay: float) -> None:
    from fbil.errors import FbilError
    from fbil.fb.config import FBTrainConfig

    with pytest.raises(FbilError, match="ema_decay"):
        FBTrainConfig(ema_decay=decay)


def test_orthogonal_init_starts_every_linear_layer_orthonormal_with_zero_biases(
    fixture_data: Path,
) -> None:
    """init="orthogonal": each weight matrix (each twin head's on its own) has orthonormal
    rows or columns and every bias is zero; the targets and the first update start from
    those weights; the default init is untouched."""
    trainer = _smoke_trainer(fixture_data, init="orthogonal")
    mats = [m.weight.T for m in trainer.model.modules() if isinstance(m, torch.nn.Linear)]
    mats += [w[k] for w in trainer.model.forward_net.heads.weights for k in range(2)]
    assert len(mats) >= 10
    for w in mats:  # (fan_in, fan_out)
        gram = w.T @ w if w.shape[0] >= w.shape[1] else w @ w.T
        torch.testing.assert_close(gram, torch.eye(gram.shape[0]), atol=1e-5, rtol=0)
    biases = [m.bias for m in trainer.model.modules() if isinstance(m, torch.nn.Linear)]
    assert all(
        torch.count_nonzero(b) == 0 for b in [*biases, *trainer.model.forward_net.heads.biases]
    )
    torch.testing.assert_close(
        trainer.f_target.heads.weights[0], trainer.model.forward_net.heads.weights[0]
    )
    trainer.update()
    default = _smoke_trainer(fixture_data)
    assert torch.count_nonzero(default.model.forward_net.heads.biases[0]) > 0


def test_independent_f_heads_train_with_a_mean_target_and_orthogonal_init(
    fixture_data: Path,
) -> None:
    """Meta's F (two independent networks, mean target) trains through the same update:
    both heads' embeddings move, the orthogonal init reaches them, and the losses stay
    finite."""
    import dataclasses

    from fbil.data import load_dataset
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    trainer = FBTrainer(
        dataclasses.replace(model_cfg, f_heads="independent"),
        dataclasses.replace(train_cfg, target_heads="mean", init="orthogonal"),
        load_dataset(fixture_data),
    )
    f = trainer.model.forward_net
    first = [emb[k][0].weight for emb in (f.sa_heads, f.sz_heads) for k in (0, 1)]
    for w in first:
        gram = w @ w.T if w.shape[0] <= w.shape[1] else w.T @ w
        torch.testing.assert_close(gram, torch.eye(gram.shape[0]), atol=1e-5, rtol=0)
    before = [w.detach().clone() for w in first]
    for _ in range(3):
        metrics = trainer.update()
    assert all(math.isfinite(float(v)) for v in metrics.values())
    assert all(not torch.equal(b, w) for b, w in zip(before, first, strict=True))


def test_traj_z_noise_perturbs_only_trajectory_rows_within_its_angle(fixture_data: Path) -> None:
    """traj_z_noise: each trajectory row's z is its unit mean plus a vector of norm at most
    the noise, projected; every other row and draw is as without it."""
    import dataclasses

    from fbil.data import load_dataset
    from fbil.errors import FbilError
    from fbil.fb.config import FBTrainConfig, preset
    from fbil.fb.train import TRAJ_Z_STATES, FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    data = load_dataset(fixture_data)
    l2 = dataclasses.replace(model_cfg, b_norm="l2")
    plain = dataclasses.replace(train_cfg, z_from_traj_ratio=0.4, precision="fp32")
    noisy = dataclasses.replace(plain, traj_z_noise=0.67)
    a, b = FBTrainer(l2, plain, data), FBTrainer(l2, noisy, data)
    ba, bb = a.sample(), b.sample()
    assert ba.traj_noise is None and bb.traj_noise is not None
    for field in ("obs", "action", "z_gauss", "perm", "use_b", "noise", "use_traj", "traj_obs"):
        assert torch.equal(getattr(ba, field), getattr(bb, field)), field
    norms = bb.traj_noise.norm(dim=-1)
    assert float(norms.max()) <= 0.67 + 1e-5 and float(norms.std()) > 0.05  # uniform scales
    with torch.no_grad():
        za, zb = a.fb_losses(ba, frozen=False)["z"], b.fb_losses(bb, frozen=False)["z"]
        b_traj = b.model.backward_net(bb.traj_obs.reshape(-1, l2.obs_dim))
    rows = bb.use_traj
    assert rows is not None and bool(rows.any())
    torch.testing.assert_close(za[~rows], zb[~rows])  # the same networks (same seed)
    unit = torch.nn.functional.normalize(
        b_traj.reshape(len(rows), TRAJ_Z_STATES, -1).mean(1), dim=-1
    )
    want = b.model.project_z(unit + bb.traj_noise)
    torch.testing.assert_close(zb[rows], want[rows])
    cos = torch.nn.functional.cosine_similarity(zb[rows], unit[rows], dim=-1)
    # A unit vector plus one of norm r < 1 turns by at most asin(r): cos >= sqrt(1 - r^2).
    assert float(cos.min()) >= (1 - 0.67**2) ** 0.5 - 1e-4
    with pytest.raises(FbilError, match="z_from_traj_ratio > 0"):
        FBTrainConfig(traj_z_noise=0.5)
    with pytest.raises(FbilError, match="traj_z_noise must be >= 0"):
        FBTrainConfig(z_from_traj_ratio=0.25, traj_z_noise=-0.1)


def test_segment_states_stay_in_the_start_transitions_episode() -> None:
    """The segment sampler shared by training and scripts/z_coverage.py: every row's states
    are next states of one episode, at or after its start transition's next state."""
    from fbil.fb.train import TRAJ_Z_STATES, episode_last_transition, segment_states

    lengths = [5, 3, 900, 2, 40]  # states per episode; the first state of each is a reset
    first = torch.tensor([0, *torch.tensor(lengths).cumsum(0)[:-1].tolist()])
    episode = torch.repeat_interleave(torch.arange(len(lengths)), torch.tensor(lengths))
    nxt = torch.tensor([i for i in range(sum(lengths)) if i not in set(first.tolist())])
    last = episode_last_transition(nxt)
    assert torch.equal(episode[nxt[last]], episode[nxt])
    assert torch.equal(
        nxt[last] + 1, torch.tensor([*first[1:].tolist(), sum(lengths)])[episode[nxt]]
    )
    at = segment_states(nxt, last, 4000, torch.Generator().manual_seed(0))
    assert at.shape == (4000, TRAJ_Z_STATES)
    assert bool((episode[at] == episode[at[:, :1]]).all())
    assert not bool(torch.isin(at, first).any())
    assert int((at.max(1).values - at.min(1).values).max()) > 100  # long spans are drawn
