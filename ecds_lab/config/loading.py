"""Read YAML into pydantic models with one clear message per problem: file, field, allowed values.

Config files are small and hand-written, so reading one is bounded: at most ``MAX_FILE_BYTES``,
strict UTF-8, no key given twice, no number that is not finite, at most ``MAX_VALUES`` values after
YAML aliases are expanded and at most ``MAX_DEPTH`` levels of nesting. Aliases stay allowed (a shared
frequency list is a fair use) but are counted as expanded, so a "billion laughs" document is refused
in time linear in its size instead of hanging the validation that would walk every copy.
"""

from __future__ import annotations

import math
import types
from pathlib import Path
from typing import Annotated, Any, TypeVar, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, TypeAdapter, ValidationError

from ecds_lab.errors import ConfigError

M = TypeVar("M", bound=BaseModel)

MAX_FILE_BYTES = 1 << 20
MAX_VALUES = 100_000
MAX_DEPTH = 50
MERGE_TAG = "tag:yaml.org,2002:merge"


def read_text(path: Path) -> str:
    """A config file's text: missing, unreadable, oversized or non-UTF-8 files raise ConfigError naming it."""
    try:
        with open(path, "rb") as file:
            data = file.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:
        raise ConfigError(f"{path}: larger than {MAX_FILE_BYTES // 1024} KiB; "
                          f"a station, experiment or sensor file is a few KiB")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ConfigError(f"{path}: not valid UTF-8 at byte {exc.start} (line {line}, byte "
                          f"{data[exc.start:exc.start + 1]!r}); save the file as UTF-8") from None
    return text.removeprefix("\ufeff")  # a byte-order mark (Windows editors) is not content


def _key_path(path: str, key: Any) -> str:
    return f"{path}.{key}" if path else str(key)


def _check_nodes(root: yaml.Node, source: str) -> None:
    """Refuse duplicate keys, recursive aliases, too deep nesting and too many values once aliases expand.

    Walks the composed node graph once: a node reached again through an alias is not walked again,
    its expanded size is remembered, so the work stays linear in the file's size.
    """
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()

    def where(node: yaml.Node) -> str:
        return f"line {node.start_mark.line + 1}"

    def walk(node: yaml.Node, path: str, depth: int) -> int:
        if id(node) in sizes:
            return sizes[id(node)]
        if id(node) in open_nodes:
            raise ConfigError(f"{source}: field '{path or '(top level)'}' ({where(node)}): an alias refers to "
                              f"a value that contains it; allowed: aliases to values defined before them")
        if depth > MAX_DEPTH:
            raise ConfigError(f"{source}: field '{path}' ({where(node)}): nested deeper than {MAX_DEPTH} levels")
        open_nodes.add(id(node))
        size = 1
        if isinstance(node, yaml.MappingNode):
            seen: dict[tuple[str, str], yaml.Node] = {}
            for key, value in node.value:
                name = key.value if isinstance(key, yaml.ScalarNode) else "?"
                if isinstance(key, yaml.ScalarNode) and key.tag != MERGE_TAG:
                    first = seen.setdefault((key.tag, key.value), key)
                    if first is not key:
                        raise ConfigError(f"{source}: field '{_key_path(path, name)}' ({where(key)}): key "
                                          f"'{name}' given twice (first on {where(first)}); give each key once")
                size += walk(key, path, depth + 1) + walk(value, _key_path(path, name), depth + 1)
        elif isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                size += walk(item, f"{path}[{i}]", depth + 1)
        open_nodes.discard(id(node))
        sizes[id(node)] = size
        if size > MAX_VALUES:
            raise ConfigError(f"{source}: field '{path or '(top level)'}' ({where(node)}): more than {MAX_VALUES} "
                              f"values once YAML aliases are expanded; allowed: at most {MAX_VALUES} values")
        return size

    walk(root, "", 0)


class ConfigLoader(yaml.SafeLoader):
    """PyYAML's safe loader, checking the composed document (``_check_nodes``) before building it."""

    source = "<text>"

    def construct_document(self, node: yaml.Node) -> Any:
        _check_nodes(node, self.source)
        return super().construct_document(node)


def _non_finite(data: Any, path: str = "") -> list[str]:
    """Field paths of every NaN or infinity in parsed data: no config value may be one."""
    if isinstance(data, float) and not math.isfinite(data):
        return [path or "(top level)"]
    if isinstance(data, dict):
        return [p for key, value in data.items() for p in _non_finite(value, _key_path(path, key))]
    if isinstance(data, list):
        return [p for i, value in enumerate(data) for p in _non_finite(value, f"{path}[{i}]")]
    return []


def parse_yaml(text: str, source: str) -> Any:
    """Parse config text (bounded, see the module docstring); problems raise ConfigError naming ``source``."""
    loader = None
    try:
        loader = ConfigLoader(text)
        loader.source = source
        data = loader.get_single_data()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(f"{source}: not valid YAML{where}: {exc.problem or exc.context}") from None
    except yaml.reader.ReaderError as exc:
        line = text.count("\n", 0, exc.position) + 1
        raise ConfigError(f"{source}: not valid YAML (line {line}): character U+{exc.character:04X} "
                          f"is not allowed in YAML") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{source}: not valid YAML: {' '.join(str(exc).split())}") from None
    except RecursionError:
        raise ConfigError(f"{source}: not valid YAML: nested too deeply "
                          f"(allowed: at most {MAX_DEPTH} levels)") from None
    finally:
        if loader is not None:
            loader.dispose()
    bad = _non_finite(data)
    if bad:
        raise ConfigError("\n".join(f"{source}: field '{field}': not a finite number (NaN and infinity are "
                                    f"not allowed); allowed: a finite number" for field in bad))
    return data


def read_yaml(path: Path) -> Any:
    """Read and parse a YAML config file; every problem raises ConfigError naming the file (and line)."""
    return parse_yaml(read_text(path), str(path))


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


#: Units of a field, read from its name's ending (SI at the edges: ``settle_s``, ``x_mm``), for bound messages.
UNITS = {"_s": "s", "_mm": "mm", "_um": "um", "_hz": "Hz", "_c": "C", "_k": "K", "_k_per_min": "K/min",
         "_w": "W", "_v": "V", "_a": "A", "_ohm": "Ohm"}
BOUNDS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")
MAX_SHOWN = 80


def unit_of(loc: list[Any]) -> str:
    """The unit a field's name ends in (``window_s`` -> "s"), "" if none."""
    name = next((part for part in reversed(loc) if isinstance(part, str)), "")
    endings = sorted((e for e in UNITS if name.endswith(e)), key=len, reverse=True)
    return UNITS[endings[0]] if endings else ""


def _shown(value: Any) -> str:
    """A given value for a message, cut short: an input can be a long list."""
    text = repr(value)
    return text if len(text) <= MAX_SHOWN else text[:MAX_SHOWN - 3] + "..."


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
        elif item["type"] in BOUNDS and unit_of(loc):
            message += f" {unit_of(loc)}"
        given = item.get("input")
        hidden = item["type"] in ("missing", "extra_forbidden") or isinstance(given, dict)
        shown = "" if hidden else f" (given: {_shown(given)})"
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
