"""``--help`` (issue 29): what an option takes reads as a value (nothing beside a flag,
never ``<bool>``), arguments as ``FILE`` in the usage line, and one example per
command that names the command itself."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.cli.help_types import EXAMPLES, value_word

runner = CliRunner()


@pytest.mark.parametrize("command", sorted(EXAMPLES))
def test_every_command_has_an_example_and_no_python_types(command):
    r = runner.invoke(app, [*command.split(), "--help"], env={"COLUMNS": "100"})
    assert r.exit_code == 0, r.output
    text = r.output
    assert f"Example: pipeline {command} " in " ".join(text.split())
    for typer_word in ("<bool>", "<str>", "<float>", "<int>", "<path>", "list[str]", "{"):
        assert typer_word not in text, (command, typer_word)


def test_identify_shows_value_words_and_bare_flags():
    r = runner.invoke(app, ["identify", "--help"], env={"COLUMNS": "120"})
    lines = {ln.split()[1]: ln for ln in r.output.splitlines()
             if ln.startswith("│") and len(ln.split()) > 2 and ln.split()[1].startswith("--")}
    assert "identify [OPTIONS] FILE" in r.output
    assert lines["--json"].split()[2] == "print"  # a flag: its help follows, no type
    assert lines["--out"].split()[2] == "PATH"
    assert lines["--events"].split()[2] == "TEXT"
    assert value_word("<list[str]>") == "TEXT" and value_word("<float>") == "NUMBER"
    assert value_word("<a|b>") == "a|b" and value_word(None) is None
