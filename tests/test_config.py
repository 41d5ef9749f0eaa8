"""Config validation: one line naming the key path and what was expected."""

import pytest

from pipeline.config import config_from_dict, load_config
from pipeline.errors import UserError


@pytest.mark.parametrize("raw,expected", [
    ({"data": {"dataset": "daisy-heating", "inptu": "u"}}, "unknown key 'data.inptu'"),
    ({"dat": {"dataset": "daisy-heating"}}, "unknown key 'dat'"),
    ({"data": {"dataset": "x"}, "methods": ["foo"]}, "unknown method 'foo'"),
    ({"data": {"path": "a.csv", "input": "u", "output": "y", "sample_time": -1}},
     "key 'data.sample_time'"),
    ({"data": {"path": "a.mcap", "input": {"topic": "/a", "feild": "x"}, "output": "y"}},
     "unknown key 'data.input.feild'"),
    ({"data": {"path": "a.csv"}}, "'input' and 'output' are required"),
    ({"data": {"path": "a.csv", "dataset": "d", "input": "u", "output": "y"}},
     "exactly one of dataset, path or paths"),
    ({"data": {"dataset": "d"}, "identification": {"events": [-1]}},
     "key 'identification.events'"),
])
def test_bad_configs_name_the_key(raw, expected):
    with pytest.raises(UserError) as exc:
        config_from_dict(raw, source="c.yaml")
    assert expected in exc.value.message
    assert exc.value.message.startswith("c.yaml: ")
    assert "\n" not in exc.value.message


def test_yaml_syntax_error_names_the_line(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("name: x\ndata:\n  dataset: [unclosed\n")
    with pytest.raises(UserError) as exc:
        load_config(p)
    assert str(p) in exc.value.message and "line" in exc.value.message


def test_missing_config_file(tmp_path):
    with pytest.raises(UserError, match="config file not found"):
        load_config(tmp_path / "nope.yaml")


def test_flagship_config_is_valid():
    from pathlib import Path

    cfg = load_config(Path(__file__).parent.parent / "configs" / "thermal.yaml")
    assert cfg.data.dataset == "daisy-heating" and cfg.data.initial_input == 6.0
    assert cfg.identification.events == [0]


def test_empty_method_list_is_rejected():
    with pytest.raises(UserError, match="non-empty list"):
        config_from_dict({"data": {"dataset": "d"}, "methods": []}, source="c.yaml")
