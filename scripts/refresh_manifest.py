"""Re-record the sha256 of an artifact folder's files after some were regenerated, keeping
its manifest's other fields, and add the regeneration's commands as notes.

Usage: python scripts/refresh_manifest.py DIR [--note KEY=TEXT ...]
Then `fbil.artifacts.verify(DIR)` passes again; the notes say how the new files were made.
"""

from __future__ import annotations

import argparse
import sys

from fbil.artifacts import refresh_manifest, verify
from fbil.errors import FbilError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory")
    parser.add_argument("--note", action="append", default=[], metavar="KEY=TEXT")
    args = parser.parse_args(argv)
    notes = {}
    for item in args.note:
        key, sep, text = item.partition("=")
        if not sep or not key:
            print(f"error: --note {item!r} is not KEY=TEXT", file=sys.stderr)
            return 2
        notes[key] = text
    try:
        refresh_manifest(args.directory, notes)
        verify(args.directory)
    except FbilError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{args.directory}/manifest.json: sha256 refreshed, {len(notes)} note(s) added")
    return 0


if __name__ == "__main__":
    sys.exit(main())
