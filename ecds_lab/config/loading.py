"""Read YAML into pydantic models with one clear message per problem: file, field, allowed values."""

from __future__ import annotations

import types
from pathlib import Path
from typing import Annotated, Any, TypeVar, Union, get_args, get_origin

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


def _members(annotation: Any) -> list[Any]:
    """The alternatives of a type: the members of a union (or Optional), Annotated unwrapped."""
    origin = get_origin(annotation)
    if origin is Annotated:
        return _members(get_args(annotation)[0])
    if origin is Union or origin is types.UnionType:
        return [member for arg in get_args(annotation) for member in _members(arg)]
    return [annotation]


def _is_model(annotation: Any) -> bool:
    return isinstance(annotation, type) and issubclass(annotation, BaseModel)


def allowed_keys(annotation: Any, loc: list[Any]) -> list[str]:
    """The keys a file may use where ``loc`` points (for an unknown key there); [] if that is not a model."""
    candidates = _members(annotation)
    for part in loc[:-1]:
        inner: list[Any] = []
        for member in candidates:
            if _is_model(member) and part in member.model_fields:
                inner += _members(member.model_fields[part].annotation)
            elif get_origin(member) is dict and isinstance(part, str):
                inner += _members(get_args(member)[1])
            elif get_origin(member) is list and isinstance(part, int):
                inner += _members(get_args(member)[0])
        # a discriminated union names its chosen member in the location: keep that member
        tagged = [m for m in candidates if _is_model(m) and "kind" in m.model_fields
                  and get_args(m.model_fields["kind"].annotation) == (part,)]
        candidates = tagged or inner
    return sorted({name for member in candidates if _is_model(member) for name in member.model_fields})


def describe_validation_error(source: str, error: ValidationError, tag: str | None = None,
                              annotation: Any = None) -> str:
    """Turn pydantic's errors into lines naming the field, the value given and what is allowed."""
    lines = []
    for item in error.errors():
        loc = list(item["loc"])
        known = allowed_keys(annotation, loc) if item["type"] == "extra_forbidden" and annotation else []
        if tag is not None and loc and loc[0] == tag:  # the union member's name is not a field of the file
            loc = loc[1:]
        field = ".".join(str(part) for part in loc) or "(top level)"
        message = item["msg"].removeprefix("Value error, ")
        if item["type"] == "extra_forbidden":
            message = "unknown key (check spelling)" + (f"; allowed: {', '.join(known)}" if known else "")
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
        annotation = getattr(model, "_type", None) if isinstance(model, TypeAdapter) else model
        raise ConfigError(describe_validation_error(source, exc, tag, annotation)) from None


def load_yaml_model(path: Path, model: type[M] | TypeAdapter[Any]) -> Any:
    """Read and validate a YAML file."""
    return validate(str(path), read_yaml(path), model)
