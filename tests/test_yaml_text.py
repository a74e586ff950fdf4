"""core/yaml_text.py reads YAML as yaml.safe_load does (libyaml's parser, when there is one, is only faster): the same
values for every YAML file the package ships, and the same error, quoting the line, for a broken one."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from racecar_sim.core import yaml_text

SHIPPED = sorted((Path(__file__).resolve().parents[1] / "src" / "racecar_sim").rglob("*.yaml"))


def test_every_shipped_yaml_file_reads_as_safe_load_reads_it():
    assert len(SHIPPED) >= 5
    for path in SHIPPED:
        text = path.read_text()
        assert yaml_text.safe_load(text) == yaml.safe_load(text), path


def test_tags_dates_and_numbers_as_safe_load_makes_them():
    text = "a: 2024-01-02\nb: 1e3\nc: 0x10\nd: ~\ne: [yes, no, on]\nf: .inf\ng: '007'\n"
    assert yaml_text.safe_load(text) == yaml.safe_load(text)
    with pytest.raises(yaml.YAMLError):  # a Python object tag stays refused, as safe_load refuses it
        yaml_text.safe_load("x: !!python/object/apply:os.system ['true']\n")


def test_a_broken_document_gives_safe_loads_own_error():
    text = "servo:\n  gain: [1, 2\n  other: 3\n"
    with pytest.raises(yaml.YAMLError) as ours:
        yaml_text.safe_load(text)
    with pytest.raises(yaml.YAMLError) as theirs:
        yaml.safe_load(text)
    assert str(ours.value) == str(theirs.value) and "line" in str(ours.value)
