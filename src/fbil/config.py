"""Frozen dataclass configs that refuse unknown fields, to and from JSON."""

from __future__ import annotations

import dataclasses
import typing
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


def setting_paths(config: Any, prefix: str = "") -> list[str]:
    """Every leaf setting of a (nested) dataclass config, as dotted paths: 'dual.lr', ..."""
    paths = []
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            paths += setting_paths(value, f"{prefix}{f.name}.")
        else:
            paths.append(prefix + f.name)
    return paths


def convert_text(current: Any, text: str) -> Any:
    """`text` as a value of `current`'s type (a number when `current` is None); ValueError
    when it is not one."""
    if isinstance(current, bool):
        if text.lower() not in ("true", "false", "1", "0"):
            raise ValueError(text)
        return text.lower() in ("true", "1")
    return float(text) if current is None else type(current)(text)


def _convert(path: str, current: Any, text: str, choices: tuple[Any, ...]) -> Any:
    """`text` as a value of `current`'s type (a Literal's `choices` checked)."""
    try:
        value = convert_text(current, text)
    except ValueError:
        kind = "number" if current is None else type(current).__name__
        raise FbilError(f"setting {path}={text!r}: not a valid {kind}") from None
    if choices and value not in choices:
        valid = ", ".join(map(str, choices))
        raise FbilError(f"setting {path}={text!r}: valid values are {valid}")
    return value


def override(config: C, path: str, text: str) -> C:
    """`config` (a frozen dataclass, nested ones included) with the setting at the dotted
    `path` ('dual.divergence') set to `text` converted to that setting's type; the config's
    own checks (`__post_init__`) run on the result. An unknown path or a value of the wrong
    type is a one-line error naming the valid ones."""

    def set_in(node: Any, parts: list[str]) -> Any:
        head, rest = parts[0], parts[1:]
        names = {f.name for f in dataclasses.fields(node)}
        current = getattr(node, head, None) if head in names else None
        nested = dataclasses.is_dataclass(current) and not isinstance(current, type)
        if head not in names or bool(rest) != nested:
            raise FbilError(f"unknown setting {path!r}; valid: {', '.join(setting_paths(config))}")
        if rest:
            value = set_in(current, rest)
        else:
            hint = typing.get_type_hints(type(node)).get(head)
            literal = typing.get_origin(hint) is typing.Literal
            value = _convert(path, current, text, typing.get_args(hint) if literal else ())
        return dataclasses.replace(node, **{head: value})

    return set_in(config, path.split("."))
