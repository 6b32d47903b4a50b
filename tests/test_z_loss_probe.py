"""scripts/z_loss_probe.py on the committed maze model and a committed demonstration."""

from pathlib import Path

import pytest

from tests.script_module import load_script

ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"
probe = load_script("z_loss_probe")


def test_each_gradient_method_lowers_its_own_loss_from_erfbs_warm_start() -> None:
    from fbil.fb.model import FBModel
    from fbil.imitation.demos import Demos

    model = FBModel.load(ARTIFACTS / "models" / "point_mass_maze")
    demos = Demos.load(ARTIFACTS / "demos" / "point_mass_maze" / "loop.npz")
    rows = {
        m: (fm, dm, cos) for m, fm, dm, cos in probe.probe(model, demos, ["erfb", "fmfb", "dmfb"])
    }
    assert rows["erfb"][2] == pytest.approx(1.0)
    assert rows["fmfb"][0] <= rows["erfb"][0]  # FMFB descends the FM loss from ERFB's z
    assert rows["dmfb"][1] <= rows["erfb"][1]  # DMFB descends the DM loss from ERFB's z


def test_no_matching_demonstration_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = str(ARTIFACTS / "models" / "point_mass_maze")
    assert probe.main([model, str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no demonstrations" in err[0]
