"""`scripts/z_drift.py`: one cosine per draw and method, within [-1, 1], and the same z's
as `imitate` gives; mistakes are one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from fbil.evaluation.evaluate import demo_draw
from fbil.fb.model import FBModel
from fbil.imitation import Demos, imitate
from tests.script_module import load_script

DEMOS = Path(__file__).resolve().parents[2] / "artifacts" / "demos" / "point_mass_maze"


def test_cosines_per_draw_against_the_erfb_warm_start(smoke_model_dir: Path) -> None:
    model, demos = FBModel.load(smoke_model_dir), Demos.load(DEMOS / "loop.npz")
    got = load_script("z_drift").cosines(model, demos, ["dmfb", "fblossfb"], draws=2, k=1)
    assert set(got) == {"dmfb", "fblossfb"} and all(len(v) == 2 for v in got.values())
    group = demo_draw(demos, 1, 1)
    z0, z = imitate(model, group, "erfb").z.flatten(), imitate(model, group, "dmfb").z.flatten()
    want = float(torch.nn.functional.cosine_similarity(z, z0, dim=0))
    assert got["dmfb"][1] == pytest.approx(want, abs=1e-6)
    assert all(-1.0 <= c <= 1.0 + 1e-6 for v in got.values() for c in v)


def test_cli_json_and_one_line_errors(
    smoke_model_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = load_script("z_drift")
    out = tmp_path / "d.json"
    base = [str(smoke_model_dir), "--demos", str(DEMOS), "--tasks", "loop", "--draws", "1"]
    args = [*base, "--methods", "bbellfb", "--actor-check", "--json", str(out)]
    assert script.main(args) == 0
    row = json.loads(out.read_text())["rows"][0]
    assert list(row["tasks"]) == ["loop"] and len(row["tasks"]["loop"]["bbellfb"]) == 1
    assert set(row["mean"]) == {"bbellfb", "erfb_actor_gap", "bbellfb_actor_gap"}
    for extra in (["--methods", "erfb"], ["--tasks", "nowhere"]):
        assert script.main([*base, *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("z_drift: error:"), err


def test_actor_check_adds_one_gap_per_draw_for_every_z(smoke_model_dir: Path) -> None:
    from fbil.evaluation.implied import actor_check

    model, demos = FBModel.load(smoke_model_dir), Demos.load(DEMOS / "loop.npz")
    got = load_script("z_drift").cosines(model, demos, ["dmfb"], draws=2, k=1, actor=True)
    assert set(got) == {"dmfb", "erfb_actor_gap", "dmfb_actor_gap"}
    assert all(len(v) == 2 for v in got.values())
    # ERFB's gap on draw 0: the probe's own check on every 10th state of that demo.
    group = demo_draw(demos, 1, 0)
    t = group.trajectories[0]
    obs = torch.as_tensor(t.observation[:-1:10]).float()
    act = torch.as_tensor(t.action[::10]).float()
    want = actor_check(model, imitate(model, group, "erfb").z.flatten(), obs, act, 64)
    assert got["erfb_actor_gap"][0] == pytest.approx(want["actor_gap"], abs=1e-6)


def test_all_tasks_are_the_domains_standard_demo_files(smoke_model_dir: Path) -> None:
    from fbil.envs import get_domain
    from fbil.evaluation.benchmark import load_task_demos

    got = load_task_demos(DEMOS, "all", "point_mass_maze")
    assert list(got) == list(get_domain("point_mass_maze").task_names)  # no *_shifted files
