"""A workbook that would abort the reader (issue 31): a zip bomb (a 0.5 MB xlsx that
expanded to hundreds of MB ended in SIGABRT), or XML that needs more memory than the
process has, is one line and exit 2 before the reader starts; a plain workbook loads."""

from __future__ import annotations

import io
import zipfile

import polars as pl
import pytest
from typer.testing import CliRunner

from pipeline import memory
from pipeline.cli.commands import app
from pipeline.io import excel
from tests.corpus import step_csv

ARGS = ["--input", "u", "--output", "y", "--time", "time", "--method", "first_order", "-q"]


@pytest.fixture(scope="module")
def workbooks(tmp_path_factory):
    d = tmp_path_factory.mktemp("books")
    plain = d / "plain.xlsx"
    pl.read_csv(io.StringIO(step_csv())).write_excel(plain, worksheet="log")
    bomb = d / "bomb.xlsx"
    with zipfile.ZipFile(plain) as src, zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename.startswith("xl/worksheets/sheet"):
                end = data.index(b"</sheetData>")
                row = b'<row r="9"><c r="A9"><v>1</v></c><c r="B9"><v>1</v></c></row>'
                with z.open(info.filename, "w", force_zip64=True) as f:
                    f.write(data[:end])
                    for _ in range((excel.BOMB_SIZE + (8 << 20)) // (len(row) * 4096)):
                        f.write(row * 4096)
                    f.write(data[end:])
            else:
                z.writestr(info, data)
    return plain, bomb


def _identify(path):
    res = CliRunner().invoke(app, ["identify", str(path), *ARGS])
    lines = [x for x in res.stderr.splitlines() if x.strip()]
    return res.exit_code, lines


def test_a_zip_bomb_is_refused_before_reading(workbooks):
    plain, bomb = workbooks
    before = bomb.read_bytes()
    assert len(before) < (2 << 20)  # a small file ...
    with zipfile.ZipFile(bomb) as z:  # ... whose sheet expands beyond the limits
        assert max(i.file_size for i in z.infolist()) > excel.BOMB_SIZE
    code, lines = _identify(bomb)
    assert code == 2 and len(lines) == 1, lines
    assert "bomb.xlsx" in lines[0] and "zip bomb" in lines[0] and "times" in lines[0]
    assert bomb.read_bytes() == before
    assert _identify(plain)[0] == 0  # the twin


def test_xml_beyond_the_memory_left_is_refused(workbooks, monkeypatch):
    plain, _ = workbooks
    monkeypatch.setattr(memory, "available", lambda: 1000)
    code, lines = _identify(plain)
    assert code == 2 and len(lines) == 1, lines
    assert "needs about" in lines[0] and "is available" in lines[0] and "CSV" in lines[0]
    monkeypatch.setattr(memory, "available", lambda: None)  # nothing known: read it
    assert _identify(plain)[0] == 0


def test_available_memory_is_known_here():
    free = memory.available()
    assert free is None or free > 0
