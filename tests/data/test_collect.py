"""Collection: resumable after SIGKILL, nothing lost, nothing duplicated."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fbil.data import list_episodes, load_dataset, load_episode
from fbil.data.collect import collect
from fbil.errors import FbilError


def _cmd(out: Path, *extra: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "fbil",
        "collect",
        "point_mass_maze",
        "--explorer",
        "rnd",
        "--episodes",
        "8",
        "--num-envs",
        "2",
        "--agents",
        "2",
        "--out",
        str(out),
        "--threads",
        "1",
        *extra,
    ]


def test_sigkill_then_resume_loses_and_duplicates_nothing(tmp_path: Path) -> None:
    out = tmp_path / "maze"
    proc = subprocess.Popen(_cmd(out), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.time() + 120
    while time.time() < deadline and len(list((out / "buffer").glob("*.npz"))) < 4:
        time.sleep(0.05)
    assert proc.poll() is None, f"collection ended early: {proc.stderr.read().decode()[-300:]}"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    before = {f.index: f.path.read_bytes() for f in list_episodes(out)}
    assert 4 <= len(before) < 8
    res = subprocess.run(
        _cmd(out, "--resume", "--json"), capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["episodes"] == 8
    files = list_episodes(out)
    assert [f.index for f in files] == list(range(8))
    for f in files:
        load_episode(f.path)  # every file loads
        if f.index in before:
            assert f.path.read_bytes() == before[f.index]  # kept as it was
    assert not list((out / "buffer").glob(".*"))  # no temporary leftovers
    data = load_dataset(out, domain="point_mass_maze")
    assert data.num_transitions == 8000
    # Episodes differ from each other (distinct seeds, no replayed batch).
    firsts = data.observation[data.episode_start]
    assert len(np.unique(firsts[:, 0])) == 8


def test_refuses_to_overwrite_or_to_resume_the_wrong_thing(tmp_path: Path) -> None:
    out = tmp_path / "rand"
    collect("point_mass_maze", "random", 2, out, seed=0, progress=False)
    with pytest.raises(FbilError, match="already holds 2 episodes"):
        collect("point_mass_maze", "random", 4, out, seed=0, progress=False)
    with pytest.raises(FbilError, match="explorer='random', not 'rnd'"):
        collect("point_mass_maze", "rnd", 4, out, seed=0, resume=True, progress=False)
    with pytest.raises(FbilError, match="nothing to resume"):
        collect("point_mass_maze", "random", 4, tmp_path / "new", resume=True, progress=False)
    with pytest.raises(FbilError, match="valid explorers: rnd, random"):
        collect("point_mass_maze", "curious", 4, tmp_path / "x", progress=False)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["domain"] == "point_mass_maze" and manifest["episodes"] == 2
    from fbil.artifacts import machine

    assert manifest["cpu"] == machine()  # which kind of CPU made the data (docs/datasets.md)
