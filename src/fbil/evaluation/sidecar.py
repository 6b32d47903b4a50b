"""JSON files that sit next to a domain's results and add a section to its report
(`seeds.json`, `time_to_policy.json`)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fbil.errors import FbilError


def find_sidecar(
    files: Sequence[str | Path], name: str, domain: str, remedy: str
) -> dict[str, Any] | None:
    """The JSON file `name` next to one of the results files, if it is of `domain`; a
    one-line error naming `remedy` if it is not valid JSON."""
    for f in files:
        path = Path(f).parent / name
        if path.is_file():
            try:
                found: dict[str, Any] = json.loads(path.read_text())
            except ValueError:
                raise FbilError(f"{path} is not valid JSON; {remedy}") from None
            if found.get("domain") == domain:
                return found
    return None
