"""A config key given twice is an error naming both lines (issue 31: the later value won
silently); a YAML merge (``<<: *base``) may still override what it merges."""

from __future__ import annotations

import pytest

from pipeline.config import load_config
from pipeline.errors import UserError


def test_a_key_given_twice_names_both_lines(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: x\ndata:\n  path: a.csv\n  input: u\n  output: y\n  input: v\n")
    with pytest.raises(UserError) as err:
        load_config(p)
    assert err.value.message == (f"{p}: line 6: not valid YAML (key 'input' given twice "
                                 "(first at line 4))")


def test_a_merge_may_override_what_it_merges(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: x\ndata: &d\n  path: a.csv\n  input: u\n  output: y\n"
                 "tuning:\n  <<: {rule: amigo, form: series}\n  rule: simc\n")
    cfg = load_config(p)
    assert cfg.tuning.rule == "simc" and cfg.tuning.form == "series"
    assert cfg.data.input == "u"


def test_an_alias_of_a_key_is_the_same_key(tmp_path):
    """Review: ``*k`` reuses the first key's node, so the identity test missed it."""
    p = tmp_path / "c.yaml"
    p.write_text("name: x\n&k methods: all\n*k : [first_order]\n")
    with pytest.raises(UserError, match="key 'methods' given twice"):
        load_config(p)
