import json
from pathlib import Path

import pytest

from fbil.artifacts import COMMAND_PREFIXES, refresh_manifest, sha256, verify, write_manifest
from fbil.errors import FbilError


def test_manifest_records_and_verifies_every_file(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.json").write_text("{}")
    (tmp_path / "sub" / "b.bin").write_bytes(b"\x00\x01")
    write_manifest(tmp_path, "fbil something --out X", seed=3, wall_seconds=1.5, commit="abc")
    body = json.loads((tmp_path / "manifest.json").read_text())
    assert body["sha256"] == {
        "a.json": sha256(tmp_path / "a.json"),
        "sub/b.bin": sha256(tmp_path / "sub" / "b.bin"),
    }
    assert verify(tmp_path)["seed"] == 3
    (tmp_path / "sub" / "b.bin").write_bytes(b"\x00\x02")
    with pytest.raises(FbilError, match=r"b\.bin does not match .* fbil something"):
        verify(tmp_path)
    (tmp_path / "a.json").unlink()
    with pytest.raises(FbilError, match=r"missing artifact .*a\.json"):
        verify(tmp_path)


def test_refresh_records_regenerated_files_and_keeps_the_other_fields(tmp_path: Path) -> None:
    (tmp_path / "a.json").write_text("{}")
    write_manifest(tmp_path, "fbil x", seed=1, wall_seconds=2.0, commit="abc", extra={"k": "v"})
    (tmp_path / "a.json").write_text('{"new": 1}')
    (tmp_path / "b.png").write_bytes(b"png")
    with pytest.raises(FbilError, match="does not match"):
        verify(tmp_path)
    refresh_manifest(tmp_path, {"rerun": "fbil y"})
    body = verify(tmp_path)
    assert body["sha256"] == {
        "a.json": sha256(tmp_path / "a.json"),
        "b.png": sha256(tmp_path / "b.png"),
    }
    assert (body["command"], body["k"], body["rerun"], body["seed"]) == ("fbil x", "v", "fbil y", 1)
    with pytest.raises(FbilError, match="no manifest"):
        refresh_manifest(tmp_path / "nowhere")


ARTIFACTS = Path(__file__).parents[1] / "artifacts"
FOLDERS = sorted(
    p.parent.relative_to(ARTIFACTS).as_posix()
    for pattern in ("*/manifest.json", "*/*/manifest.json")
    for p in ARTIFACTS.glob(pattern)
)


def test_every_domain_folder_of_artifacts_has_a_manifest() -> None:
    folders = {p.relative_to(ARTIFACTS).as_posix() for p in ARTIFACTS.glob("*/*") if p.is_dir()}
    assert folders <= set(FOLDERS)
    assert "models/point_mass_maze" in FOLDERS


def test_a_folder_with_its_own_manifest_is_left_to_it(tmp_path: Path) -> None:
    (tmp_path / "inner").mkdir()
    (tmp_path / "report.md").write_text("over domains")
    (tmp_path / "inner" / "a.json").write_text("{}")
    write_manifest(tmp_path / "inner", "fbil inner", seed=0, wall_seconds=1.0, commit="abc")
    write_manifest(tmp_path, "fbil outer", seed=0, wall_seconds=1.0, commit="abc")
    assert set(json.loads((tmp_path / "manifest.json").read_text())["sha256"]) == {"report.md"}
    (tmp_path / "inner" / "a.json").write_text('{"changed": 1}')
    assert verify(tmp_path)["command"] == "fbil outer"  # the inner file is not the outer's
    with pytest.raises(FbilError, match=r"a\.json does not match"):
        verify(tmp_path / "inner")


@pytest.mark.parametrize("folder", FOLDERS)
def test_committed_artifacts_match_their_manifests(folder: str) -> None:
    root = ARTIFACTS / folder
    body = verify(root)
    assert body["sha256"] and body["command"].startswith(COMMAND_PREFIXES)


@pytest.mark.parametrize("domain", ["walker", "cheetah"])
def test_a_committed_locomotion_model_is_what_the_cpu_preset_trains(domain: str) -> None:
    """`fbil pretrain DOMAIN --preset cpu` must reproduce the committed model's settings
    (its manifest says so): every model and training setting but the snapshot interval."""
    import dataclasses

    from fbil.config import config_from_dict
    from fbil.fb.config import FBModelConfig, FBTrainConfig, preset

    folder = ARTIFACTS / "models" / domain
    saved = json.loads((folder / "config.json").read_text())
    model_cfg, train_cfg = preset(domain, "cpu")
    assert config_from_dict(FBModelConfig, saved["model"]) == model_cfg
    trained = config_from_dict(FBTrainConfig, saved["train_config"])
    assert dataclasses.replace(trained, snapshot_every=0) == train_cfg
    assert verify(folder)["steps"] == train_cfg.steps


@pytest.mark.parametrize("domain", ["cheetah", "quadruped"])
def test_the_next_locomotion_domains_start_from_walkers_recipe(domain: str) -> None:
    """docs/walker.md tells cheetah and quadruped to start from walker's preset (reference
    mechanisms, 1 024-unit F, the averaged model): their `cpu` preset is walker's but for
    what Table 1 sets per domain (z size, B's normalisation, sizes from the environment)."""
    import dataclasses

    from fbil.envs.registry import get_domain
    from fbil.fb.config import preset

    walker_model, walker_train = preset("walker", "cpu")
    model, train = preset(domain, "cpu")
    spec = get_domain(domain)
    assert (model.obs_dim, model.act_dim, model.z_dim) == (spec.obs_dim, spec.act_dim, 50)
    same = dataclasses.replace(
        walker_model, obs_dim=model.obs_dim, act_dim=model.act_dim, z_dim=50, b_norm=model.b_norm
    )
    assert model == same
    assert train == walker_train
