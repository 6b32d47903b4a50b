"""Policy files: what `fbil imitate --out` writes reads back (`load_policy`) as a policy
that acts exactly as the fitted one, for every kind of file; `fbil render --policy FILE`
draws it; bad files and missing models are one-line errors."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fbil.cli import main
from fbil.data import list_episodes, load_dataset, load_episode
from fbil.errors import FbilError
from fbil.fb.model import FBModel
from fbil.imitation import Demos, Trajectory
from fbil.imitators import FitContext, fit, load_policy

# td3il: TD3's actor in bf16 (its `cpu` precision); sqil: SAC's Gaussian actor; dwbc and
# bc: the Gaussian and the plain BC networks, in fp32.
TRAINED = ("bc", "td3il", "sqil", "dwbc")


def _fbil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fbil", *args], capture_output=True, text=True, timeout=300
    )


@pytest.fixture(scope="module")
def demos(fixture_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two fixture episodes as demos of `square` (their rewards are not used here)."""
    trajs = []
    for f in list_episodes(fixture_data)[:2]:
        ep = load_episode(f.path)
        trajs.append(Trajectory(ep["observation"], ep["action"][1:], None))
    path = tmp_path_factory.mktemp("files") / "square.npz"
    Demos(trajs, {"domain": "point_mass_maze", "task": "square"}).save(path)
    return path


@pytest.mark.parametrize("name", TRAINED)
def test_a_saved_baseline_acts_as_the_fitted_one(
    name: str, demos: Path, fixture_data: Path, tmp_path: Path
) -> None:
    ctx = FitContext(dataset=load_dataset(fixture_data), budget="smoke", seed=0)
    fitted = fit(name, Demos.load(demos), ctx).policy
    path = fitted.save(tmp_path / f"{name}{fitted.suffix}")
    loaded = load_policy(path)
    obs = np.random.default_rng(0).normal(size=(64, 4)).astype(np.float32)
    np.testing.assert_array_equal(loaded.act(obs, 0), fitted.act(obs, 0))
    assert getattr(loaded, "precision", None) == getattr(fitted, "precision", None)


def test_fb_and_goal_files_read_back(demos: Path, smoke_model_dir: Path, tmp_path: Path) -> None:
    model = FBModel.load(smoke_model_dir)
    fitted = fit("goalfb", Demos.load(demos), FitContext(model=model)).policy
    path = fitted.save(tmp_path / "goalfb.json")
    obs = np.random.default_rng(1).normal(size=(8, 4)).astype(np.float32)
    loaded = load_policy(path, model)
    for step in (0, 5, 500):
        np.testing.assert_array_equal(loaded.act(obs, step), fitted.act(obs, step))
    with pytest.raises(FbilError, match="pass the model folder"):
        load_policy(path)


def test_bad_policy_files_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(FbilError, match="no policy file"):
        load_policy(tmp_path / "missing.safetensors")
    corrupt = tmp_path / "bc.safetensors"
    corrupt.write_bytes(b"not a safetensors file")
    with pytest.raises(FbilError, match="corrupt"):
        load_policy(corrupt)
    other = tmp_path / "x.json"
    other.write_text(json.dumps({"hello": 1}))
    with pytest.raises(FbilError, match="not a policy file"):
        load_policy(other)
    (tmp_path / "p.pt").write_text("")
    with pytest.raises(FbilError, match="unknown policy file type"):
        load_policy(tmp_path / "p.pt")


def test_render_draws_an_imitated_policy_file(
    demos: Path, smoke_model_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "pols"
    run = _fbil(
        "imitate", str(smoke_model_dir), str(demos), "--methods", "bc,erfb", "--budget", "smoke",
        "--out", str(out),
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    pic = tmp_path / "bc.png"
    args = ["render", "point_mass_maze", "square", "--episodes", "1", "--steps", "20", "--json"]
    assert main([*args, "--policy", str(out / "bc.safetensors"), "--out", str(pic)]) == 0
    assert pic.stat().st_size > 0 and len(json.loads(capsys.readouterr().out)["returns"]) == 1
    # An FB-IL file needs its model; a policy of another domain is refused.
    fb_file = ["--policy", str(out / "erfb.json"), "--out", str(tmp_path / "e.png")]
    assert main([*args, *fb_file]) == 2
    err = capsys.readouterr().err
    assert "--model" in err and len(err.strip().splitlines()) == 1
    assert main([*args, *fb_file, "--model", str(smoke_model_dir)]) == 0
    walker = ["render", "walker", "stand", "--steps", "5", "--out", str(tmp_path / "w.png")]
    assert main([*walker, "--policy", str(out / "bc.safetensors")]) == 2
    err = capsys.readouterr().err
    assert "walker" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "w.png").exists()
