"""Frozen dataclass configs that refuse unknown fields, to and from JSON."""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

from fbil.errors import FbilError

C = TypeVar("C")


def config_from_dict(cls: type[C], values: dict[str, Any], what: str = "config") -> C:
    """Build `cls` from a dict, naming any unknown field and the valid ones."""
    assert dataclasses.is_dataclass(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - names)
    if unknown:
        valid = ", ".join(sorted(names))
        raise FbilError(f"unknown {what} field(s) {', '.join(unknown)}; valid fields: {valid}")
    return cls(**values)


def config_to_dict(config: Any) -> dict[str, Any]:
    return dataclasses.asdict(config)
