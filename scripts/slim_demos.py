"""Rewrite demo files so that only some demos keep their physics states (`--physics first`:
the demo the report and `fbil demo` draw), the rest of each file bit for bit as it was.

Usage: python scripts/slim_demos.py FILE.npz [...] [--physics first|none] [--json OUT]

A locomotion demo file's float64 physics states are more than half its bytes and are read
only to relabel a demo's own rewards exactly, to draw it and (`scripts/goal_tracking_probe.py`)
to start a tracker inside it. Observations, actions, rewards, offsets and metadata are
compared with the original after the rewrite; a file that would change in anything but
physics is left as it was. Each rewrite is atomic. Prints one line per file (bytes before
and after, new sha256); `--json` writes the same as a list.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from fbil.artifacts import sha256
from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.imitation.demos import DEMO_PHYSICS, Demos, check_physics

SAME = ("observation", "action", "reward")  # what a rewrite must leave bit for bit


def _same(a: Demos, b: Demos) -> str | None:
    """The first difference between two demo sets outside their physics, or None."""
    if len(a) != len(b) or a.metadata != b.metadata:
        return "the number of demos or the metadata"
    for i, (s, t) in enumerate(zip(a.trajectories, b.trajectories, strict=True)):
        for key in SAME:
            x, y = getattr(s, key), getattr(t, key)
            if (x is None) != (y is None) or (x is not None and not np.array_equal(x, y)):
                return f"demo {i}'s {key}"
    return None


def slim(path: Path, which: str) -> dict[str, Any]:
    """Rewrite `path` keeping physics for `which` demos; what changed, as one record."""
    demos = Demos.load(path)
    before = path.stat().st_size
    try:
        kept = demos.keep_physics(which)
    except FbilError as e:
        raise FbilError(f"{path}: {e}") from None
    tmp = path.with_name(f".{path.stem}.slim.npz")
    try:
        kept.save(tmp)
        again = Demos.load(tmp)
        diff = _same(demos, again)
        if diff is not None:
            raise FbilError(f"{path}: rewriting would change {diff}; the file is left as it was")
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
    kept_n = sum(t.physics is not None for t in again.trajectories)
    return {"file": str(path), "bytes_before": before, "bytes_after": path.stat().st_size,
            "demos": len(again), "physics_kept": kept_n, "sha256": sha256(path)}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--physics", default="first", help=f"one of {', '.join(DEMO_PHYSICS)}")
    parser.add_argument("--json", type=Path, help="also write the records here")
    args = parser.parse_args(argv)
    try:
        check_physics(args.physics)
        records = [slim(f, args.physics) for f in args.files]
        if args.json:
            atomic_write_text(args.json, json.dumps(records, indent=1) + "\n")
    except (FbilError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for r in records:
        size = f"{r['bytes_before']:,} -> {r['bytes_after']:,} bytes"
        kept = f"physics kept for {r['physics_kept']} of {r['demos']} demos"
        print(f"{r['file']}: {size}, {kept}, sha256 {r['sha256'][:16]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
