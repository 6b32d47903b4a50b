import dataclasses
import os
import shutil
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

FIXTURE = Path(__file__).parent / "fixtures" / "exorl" / "point_mass_maze" / "rnd"


@pytest.fixture(scope="session")
def fixture_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A writable copy of the committed ExORL-layout maze fixture (4 episodes)."""
    data = tmp_path_factory.mktemp("data") / "rnd"
    shutil.copytree(FIXTURE, data)
    return data


@pytest.fixture(scope="session")
def smoke_model_dir(fixture_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An FB model of the `smoke` preset trained for a few steps on the fixture."""
    from fbil.data import load_dataset
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    model_cfg, train_cfg = preset("point_mass_maze", "smoke")
    train_cfg = dataclasses.replace(train_cfg, steps=60)
    out = tmp_path_factory.mktemp("model") / "fb"
    FBTrainer(model_cfg, train_cfg, load_dataset(fixture_data)).fit(out, progress=False)
    return out
