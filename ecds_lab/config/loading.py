"""Read YAML into pydantic models with one clear message per problem: file, field, allowed values."""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, TypeAdapter, ValidationError

from ecds_lab.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


def read_yaml(path: Path) -> Any:
    """Parse a YAML file; unreadable or malformed files raise ConfigError naming the file and line."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror}") from exc
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(f"{path}: not valid YAML{where}: {getattr(exc, 'problem', exc)}") from exc


def describe_validation_error(source: str, error: ValidationError, tag: str | None = None) -> str:
    """Turn pydantic's errors into lines naming the field, the value given and what is allowed."""
    lines = []
    for item in error.errors():
        loc = list(item["loc"])
        if tag is not None and loc and loc[0] == tag:  # the union member's name is not a field of the file
            loc = loc[1:]
        field = ".".join(str(part) for part in loc) or "(top level)"
        message = item["msg"].removeprefix("Value error, ")
        if item["type"] == "extra_forbidden":
            message = "unknown key (check spelling; see the documented fields)"
        elif item["type"] == "missing":
            message = "required field is missing"
        given = item.get("input")
        shown = "" if item["type"] in ("missing", "extra_forbidden") or isinstance(given, dict) else f" (given: {given!r})"
        lines.append(f"{source}: field '{field}': {message}{shown}")
    return "\n".join(lines)


def validate(source: str, data: Any, model: type[M] | TypeAdapter[Any]) -> Any:
    """Validate parsed data against a model (or a TypeAdapter), raising ConfigError listing every problem."""
    try:
        if isinstance(model, TypeAdapter):
            return model.validate_python(data if data is not None else {})
        return model.model_validate(data if data is not None else {})
    except ValidationError as exc:
        tag = data.get("kind") if isinstance(data, dict) else None
        raise ConfigError(describe_validation_error(source, exc, tag)) from None


def load_yaml_model(path: Path, model: type[M] | TypeAdapter[Any]) -> Any:
    """Read and validate a YAML file."""
    return validate(str(path), read_yaml(path), model)
