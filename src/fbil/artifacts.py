"""Committed artifacts and their manifests (command, commit, seed, wall time, sha256).

`write_manifest` records every file of an artifact folder with its sha256;
`verify` checks them again, so a missing or altered file is reported by name, with the
command that regenerates it."""

from __future__ import annotations

import functools
import hashlib
import json
import platform
import time
from pathlib import Path
from typing import Any

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError

MANIFEST = "manifest.json"
# A committed manifest's command starts with one of these, so a reader can paste it into a
# shell at the repository's root (an environment variable or prose goes inside, after it).
COMMAND_PREFIXES = ("fbil ", "scripts/", "python ")


def sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@functools.cache  # read /proc/cpuinfo once per process, not once per results line
def machine() -> str:
    """The CPU this process runs on and torch's kernel level, e.g. `Intel(R) Xeon(R)
    Processor, AVX512`. Runs under one seed repeat exactly on one kind of CPU; on another
    (another vendor or vector width) floating-point sums round differently, and RND
    collection, training and so every later number drift apart (docs/datasets.md)."""
    import torch

    model = platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {torch.backends.cpu.get_cpu_capability()}"


def write_manifest(
    directory: str | Path,
    command: str,
    seed: int | None,
    wall_seconds: float | None,
    commit: str,
    extra: dict[str, Any] | None = None,
) -> Path:
    directory = Path(directory)
    files = _digests(directory)
    body = {
        "command": command,
        "git_commit": commit,
        "seed": seed,
        "wall_seconds": wall_seconds,
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "sha256": files,
        **(extra or {}),
    }
    return atomic_write_text(directory / MANIFEST, json.dumps(body, indent=2) + "\n")


def _digests(directory: Path) -> dict[str, str]:
    """sha256 of every file of the folder, except those of a subfolder with a manifest of
    its own (an artifact inside another one, e.g. each domain's results under the report
    over domains)."""
    nested = [m.parent for m in directory.rglob(MANIFEST) if m.parent != directory]
    return {
        p.relative_to(directory).as_posix(): sha256(p)
        for p in sorted(directory.rglob("*"))
        if p.is_file()
        and p.name != MANIFEST
        and not p.name.startswith(".")
        and not any(p.is_relative_to(n) for n in nested)
    }


def refresh_manifest(directory: str | Path, notes: dict[str, str] | None = None) -> Path:
    """Re-record the sha256 of every file of an existing manifest's folder after some of its
    files were regenerated, keeping the manifest's other fields and adding `notes` (the
    commands of the regeneration) as fields of their own."""
    directory = Path(directory)
    path = directory / MANIFEST
    if not path.is_file():
        raise FbilError(f"no manifest in {directory}; write one first with write_manifest")
    body: dict[str, Any] = json.loads(path.read_text())
    body["sha256"] = _digests(directory)
    body.update(notes or {})
    return atomic_write_text(path, json.dumps(body, indent=2, ensure_ascii=False) + "\n")


def verify(directory: str | Path) -> dict[str, Any]:
    """Check every file listed in the folder's manifest; one-line error on a mismatch."""
    directory = Path(directory)
    path = directory / MANIFEST
    if not path.is_file():
        raise FbilError(f"missing artifact manifest {path}; reinstall fbil from a clean checkout")
    body: dict[str, Any] = json.loads(path.read_text())
    for name, digest in body.get("sha256", {}).items():
        f = directory / name
        if not f.is_file():
            raise FbilError(f"missing artifact {f}; regenerate it with: {body.get('command')}")
        if sha256(f) != digest:
            raise FbilError(
                f"artifact {f} does not match its manifest (sha256); regenerate it with: "
                f"{body.get('command')}"
            )
    return body
