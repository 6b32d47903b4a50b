"""scripts/carry.sh: a run's resumable files go to carry/NAME and back unchanged; a folder
that is not a training run is refused with one line and exit 2."""

import os
import subprocess
from pathlib import Path

SCRIPT = Path(__file__).parents[1] / "scripts" / "carry.sh"
FILES = {
    "checkpoint.safetensors": b"\x00weights",
    "config.json": b"{}",
    "train_log.csv": b"step,x\n250,1\n",
}


def _carry(*args: str, root: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "CARRY_DIR": str(root)}
    return subprocess.run(["bash", str(SCRIPT), *args], env=env, capture_output=True, text=True)


def test_save_then_load_round_trips_the_resumable_files(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    for name, data in FILES.items():
        (run / name).write_bytes(data)
    (run / "snapshots").mkdir()  # not carried
    root = tmp_path / "carry"
    saved = _carry("save", str(run), "maze_s1", root=root)
    assert saved.returncode == 0, saved.stderr
    assert sorted(p.name for p in (root / "maze_s1").iterdir()) == sorted(FILES)
    loaded = _carry("load", "maze_s1", str(tmp_path / "back"), root=root)
    assert loaded.returncode == 0, loaded.stderr
    assert {n: (tmp_path / "back" / n).read_bytes() for n in FILES} == FILES
    assert "250 steps" in loaded.stdout


def test_a_goal_pretraining_run_is_carried_with_its_own_files(tmp_path: Path) -> None:
    run = tmp_path / "goal"
    run.mkdir()
    files = {"goal_checkpoint.safetensors": b"\x00w", "goal_train_log.csv": b"step,q\n3000,1\n"}
    for name, data in files.items():
        (run / name).write_bytes(data)
    root = tmp_path / "carry"
    saved = _carry("save", str(run), "cheetah_goal", root=root)
    assert saved.returncode == 0, saved.stderr
    assert sorted(p.name for p in (root / "cheetah_goal").iterdir()) == sorted(files)
    loaded = _carry("load", "cheetah_goal", str(tmp_path / "back"), root=root)
    assert loaded.returncode == 0 and "3000 steps" in loaded.stdout, loaded.stderr
    assert {n: (tmp_path / "back" / n).read_bytes() for n in files} == files


def test_a_folder_without_a_checkpoint_is_refused(tmp_path: Path) -> None:
    out = _carry("save", str(tmp_path), "x", root=tmp_path / "carry")
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "checkpoint.safetensors is missing" in out.stderr
    assert not (tmp_path / "carry").exists()
    assert _carry("push", "a", "b", root=tmp_path).returncode == 2


def test_a_benchmarks_saved_fits_are_carried_and_put_back(tmp_path: Path) -> None:
    fits = tmp_path / "runs" / ".walker_iqlearn_s0.jsonl.fits"
    fits.mkdir(parents=True)
    files = {
        "iqlearn_run_d0_s0_ab12.safetensors": b"\x00a",
        "td3il_walk_d1_s0_cd34.safetensors": b"b",
    }
    for name, data in files.items():
        (fits / name).write_bytes(data)
    (fits / ".iqlearn_run_d0_s0_ab12.safetensors.tmp").write_bytes(b"cut")  # not carried
    root = tmp_path / "carry"
    saved = _carry("save", str(fits), "walker_iqlearn_fit", root=root)
    assert saved.returncode == 0 and "2 saved fit(s)" in saved.stdout, saved.stderr
    assert sorted(p.name for p in (root / "walker_iqlearn_fit").iterdir()) == sorted(files)
    back = tmp_path / "fresh" / ".walker_iqlearn_s0.jsonl.fits"
    loaded = _carry("load", "walker_iqlearn_fit", str(back), root=root)
    assert loaded.returncode == 0, loaded.stderr
    assert {n: (back / n).read_bytes() for n in files} == files
