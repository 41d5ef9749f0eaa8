"""The hostile-input corpus (issue 13): one row per kind, through the real CLI.

The rows live in ``tests/corpus/*.py`` (see :mod:`tests.corpus`); this test is the one
place that runs them and holds the promises every row shares.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import re

import pytest
from typer.testing import CliRunner

import tests.corpus as corpus
from pipeline.cli.commands import app


def _cases() -> list[corpus.Hostile]:
    rows = []
    for info in pkgutil.iter_modules(corpus.__path__):
        rows += importlib.import_module(f"tests.corpus.{info.name}").CASES
    return rows


CASES = _cases()


def test_kinds_are_unique():
    kinds = [c.kind for c in CASES]
    assert len(kinds) == len(set(kinds))


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.kind)
def test_hostile(case: corpus.Hostile, tmp_path, monkeypatch):
    for name, content in case.files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")
    for name, target in case.links.items():
        link = tmp_path / name
        link.parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target.replace("{d}", str(tmp_path)), link)
    before = {k: (tmp_path / k).read_bytes() for k in case.keep}
    monkeypatch.chdir(tmp_path)
    args = [a.replace("{d}", str(tmp_path)) for a in case.args]
    result = CliRunner().invoke(app, args, catch_exceptions=True)
    err = result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        f"raised {result.exception!r}")
    assert result.exit_code == case.code, f"exit {result.exit_code}; stderr:\n{err}"
    assert "Traceback" not in err and "Traceback" not in result.stdout
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) <= case.max_lines, err
    for needle in case.stderr:
        assert needle in err, err
    for secret in case.absent:
        assert secret not in err and secret not in result.stdout, "a planted secret leaked"
    assert not re.search(r"\x1b\[", err), "raw terminal escape on stderr"
    leftovers = [p for p in tmp_path.rglob("*") if ".tmp-" in p.name or p.suffix == ".tmp"]
    assert not leftovers, leftovers
    for k, data in before.items():
        assert (tmp_path / k).read_bytes() == data, f"{k} changed"
    if case.check is not None:
        case.check(tmp_path)
