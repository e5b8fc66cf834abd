"""The YAML loader's bounds: what it refuses (naming file, field and line) and what it still reads."""

from __future__ import annotations

import pytest

from ecds_lab.config.experiment import EXPERIMENT_ADAPTER
from ecds_lab.config.loading import (
    MAX_DEPTH,
    MAX_FILE_BYTES,
    MAX_VALUES,
    load_yaml_model,
    parse_yaml,
    read_yaml,
)
from ecds_lab.errors import ConfigError

SWEEP = "kind: displacement_sweep\nsweep: {positions_mm: [20.0, 30.0], frequencies_hz: [500]}\n"


def refused(text: str) -> str:
    with pytest.raises(ConfigError) as error:
        parse_yaml(text, "f.yaml")
    message = str(error.value)
    assert message.startswith("f.yaml: ")
    return message


def test_aliases_within_the_limit_are_read():
    data = parse_yaml("freqs: &f [500, 15000]\na: *f\nb: *f\n", "f.yaml")
    assert data == {"freqs": [500, 15000], "a": [500, 15000], "b": [500, 15000]}


def test_aliases_are_counted_as_expanded():
    # l3 holds 11111 values when expanded (under MAX_VALUES), l4 ten times as many (over it)
    levels = ["l0: &l0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    levels += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 4)]
    assert len(parse_yaml("\n".join(levels), "f.yaml")["l3"]) == 10
    levels.append(f"l4: &l4 [{', '.join(['*l3'] * 10)}]")
    assert f"more than {MAX_VALUES} values once YAML aliases are expanded" in refused("\n".join(levels))


def test_a_recursive_alias_is_refused():
    assert "field 'a[1]' (line 1): an alias refers to a value that contains it" in refused("a: &x [1, *x]\n")


def test_merge_keys_are_not_duplicates_but_repeated_keys_are():
    data = parse_yaml("base: &b {x: 1, y: 2}\nd:\n  <<: *b\n  x: 3\n", "f.yaml")
    assert data["d"] == {"x": 3, "y": 2}
    assert "field 'd.x' (line 4): key 'x' given twice (first on line 3)" in refused("d:\n  y: 0\n  x: 1\n  x: 2\n")


def test_deep_nesting_is_refused():
    shallow = "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)
    parse_yaml(shallow, "f.yaml")
    assert f"nested deeper than {MAX_DEPTH} levels" in refused("[" * (MAX_DEPTH + 5) + "]" * (MAX_DEPTH + 5))
    assert "nested too deeply" in refused("[" * 5000 + "]" * 5000)  # beyond PyYAML's own recursion


def test_every_non_finite_number_is_listed():
    lines = refused("a: [1.0, .nan]\nb: {c: -.inf, d: .inf}\n").splitlines()
    assert [line.split("'")[1] for line in lines] == ["a[1]", "b.c", "b.d"]
    assert all("not a finite number" in line for line in lines)


def test_characters_yaml_forbids_name_the_line():
    assert "(line 2): character U+0007 is not allowed" in refused("a: 1\nb: \x07\n")


def test_python_tags_are_refused():
    assert "could not determine a constructor" in refused("a: !!python/object/apply:os.system [ls]\n")


def test_a_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "bom.yaml"
    path.write_bytes(b"\xef\xbb\xbf" + SWEEP.encode())
    assert load_yaml_model(path, EXPERIMENT_ADAPTER).sweep.positions_mm == [20.0, 30.0]


def test_an_oversized_file_is_refused_unread(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text("a: [" + "1, " * (MAX_FILE_BYTES // 3) + "1]\n")
    with pytest.raises(ConfigError, match=rf"^{path}: larger than {MAX_FILE_BYTES // 1024} KiB"):
        read_yaml(path)


def test_a_folder_is_refused_naming_it(tmp_path):
    with pytest.raises(ConfigError, match=rf"^{tmp_path}: cannot read: "):
        read_yaml(tmp_path)


def test_bounds_carry_the_unit_of_the_field(tmp_path):
    path = tmp_path / "e.yaml"
    path.write_text(SWEEP.replace("frequencies_hz", "settle_s: -1, frequencies_hz"))
    with pytest.raises(ConfigError) as error:
        load_yaml_model(path, EXPERIMENT_ADAPTER)
    assert str(error.value) == (f"{path}: field 'sweep.settle_s': Input should be greater than or equal to 0 s "
                                "(given: -1)")


def test_long_values_are_cut_short_in_messages(tmp_path):
    path = tmp_path / "e.yaml"
    path.write_text(SWEEP.replace("[500]", "[" + ", ".join(["12345"] * 200) + "]"))
    with pytest.raises(ConfigError) as error:
        load_yaml_model(path, EXPERIMENT_ADAPTER)
    assert "field 'sweep.frequencies_hz'" in str(error.value) and len(str(error.value)) < 1000
