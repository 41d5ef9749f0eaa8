"""The format registry: every format loads its example; every data key belongs to formats.

The cases are tables over the registry, so a new format is covered once it is registered
and has an entry in EXAMPLES (a missing entry fails the conformance test).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app
from pipeline.config import config_from_dict
from pipeline.errors import UserError
from pipeline.io import FORMATS, DataConfig, load_record
from pipeline.io.options import FORMAT_KEYS
from pipeline.io.registry import NAMES
from pipeline.run import effective_data, resolve_specs

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES_DIR = ROOT / "datasets" / "examples"
CSV = str(EXAMPLES_DIR / "jakoubek" / "system1.csv")
MCAP = str(EXAMPLES_DIR / "lamp_plate.mcap")

#: format -> a data section that loads the format's example, and its sample count; the
#: relative paths are written from the CSV example by the ``written`` fixture
EXAMPLES: dict[str, tuple[dict, int]] = {
    "csv": ({"path": CSV, "input": "u", "output": "y", "time": "time"}, 2301),
    "dat": ({"dataset": "daisy-heating", "columns": ["time", "u", "y"]}, 801),
    "mat": ({"dataset": "daniw-dc-step"}, 1101),
    "xlsx": ({"path": "system1.xlsx", "sheet": "log", "input": "u", "output": "y",
              "time": "time"}, 2301),
    "parquet": ({"path": "system1.parquet", "input": 1, "output": "y", "time": 0}, 2301),
    "mcap": ({"path": MCAP, "input": {"topic": "/lamp/cmd", "field": "data"},
              "output": {"topic": "/plate/temp", "field": "temperature.value"},
              "sample_time": 0.5, "max_gap": 5.0}, 600),
}

#: a value of the right type for every format key (to give it where it does not apply)
VALUES = {"time": "time", "sample_time": 0.5, "columns": ["time", "u", "y"],
          "stamp": "header.stamp", "max_gap": 5.0, "time_unit": "ms", "time_zone": "UTC",
          "time_format": "%Y-%m-%d %H:%M:%S", "delimiter": "comma", "decimal": ".",
          "header": True, "sheet": "log", "duplicates": "mean", "fill_gaps": 2,
          "long_gaps": "keep_longest", "trailing_lines": "skip", "skip_rows": 2,
          "unwrap": 360.0}


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> Path:
    """The CSV example as a workbook and a Parquet file."""
    import polars as pl

    folder = tmp_path_factory.mktemp("examples")
    frame = pl.read_csv(CSV)
    frame.write_excel(folder / "system1.xlsx", worksheet="log")
    frame.write_parquet(folder / "system1.parquet")
    return folder


def _load(section: dict, base: Path = ROOT):
    cfg = config_from_dict({"data": section}, source="c.yaml", base_dir=str(base))
    (spec,) = resolve_specs(cfg)
    return load_record(Path(spec.path), effective_data(cfg, spec), name=spec.name)


@pytest.mark.parametrize("name", FORMATS)
def test_every_format_loads_its_example(name, written):
    section, n = EXAMPLES[name]
    rec = _load(section, written if not Path(section.get("path", "/")).is_absolute() else ROOT)
    assert rec.n_samples == n
    assert Path(rec.source).suffix in FORMATS[name].suffixes


def _misplaced() -> list[tuple[str, str]]:
    """Every (format, key of another format) pair the registry makes."""
    return [(name, key) for name, fmt in FORMATS.items() for key in FORMAT_KEYS
            if key not in fmt.keys]


@pytest.mark.parametrize("name,key", _misplaced())
def test_a_key_of_another_format_is_one_line(name, key):
    section = {**EXAMPLES[name][0], key: VALUES[key]}
    owners = ", ".join(n for n, f in FORMATS.items() if key in f.keys)
    expected = (f"c.yaml: key 'data.{key}' does not apply to {name} files "
                f"(it is an option of: {owners})")
    with pytest.raises(UserError) as exc:
        config_from_dict({"data": section}, source="c.yaml")
    assert exc.value.message == expected


@pytest.mark.parametrize("section,expected", [
    # the two wordings, pinned
    ({"path": "logs/a.dat", "input": "u", "output": "y", "stamp": "header.stamp"},
     "c.yaml: key 'data.stamp' does not apply to dat files (it is an option of: mcap)"),
    ({"path": "a.mcap", "input": {"topic": "/u", "field": "data"},
      "output": {"topic": "/y", "field": "data"}, "columns": ["t", "u", "y"]},
     "c.yaml: key 'data.columns' does not apply to mcap files (it is an option of: csv, dat, "
     "xlsx)"),
    # the format known from a glob's suffix, a declared format, a list of paths, a dataset
    ({"path": "logs/*.csv", "input": "u", "output": "y", "max_gap": 2.0},
     "c.yaml: key 'data.max_gap' does not apply to csv files (it is an option of: mcap)"),
    ({"path": "logs/a.log", "format": "csv", "input": "u", "output": "y", "sheet": 1},
     "c.yaml: key 'data.sheet' does not apply to csv files (it is an option of: xlsx)"),
    ({"path": "logs/a.log", "format": "tsv", "input": "u", "output": "y", "sheet": 1},
     "c.yaml: key 'data.sheet' does not apply to csv files (it is an option of: xlsx)"),
    ({"paths": ["a.csv", "b.mcap"], "input": "u", "output": "y", "stamp": "s"},
     "c.yaml: key 'data.stamp' does not apply to csv files (it is an option of: mcap)"),
    ({"dataset": "daisy-heating", "stamp": "header.stamp"},
     "c.yaml: key 'data.stamp' does not apply to dat files (it is an option of: mcap)"),
    # a key no format takes: unknown, whatever the format
    ({"path": "a.csv", "input": "u", "output": "y", "stamp_field": "x"},
     "c.yaml: unknown key 'data.stamp_field' (did you mean 'stamp'?)"),
    ({"path": "logs/", "input": "u", "output": "y", "foo": 1},
     "c.yaml: unknown key 'data.foo'; check its spelling (the keys there: dataset, path, "
     "paths, format, input, output, initial_input, setpoint, units, trailing_lines, "
     "skip_rows, columns, header, "
     "duplicates, fill_gaps, long_gaps, unwrap, time, sample_time, time_unit, time_zone, "
     "time_format, delimiter, decimal, sheet, stamp, max_gap)"),
    ({"dataset": "daisy-heating", "colums": ["t", "u", "y"]},
     "c.yaml: unknown key 'data.colums' (did you mean 'columns'?)"),
    # a format key's value is checked where the key is declared
    ({"path": "logs/", "input": "u", "output": "y", "max_gap": -1},
     "c.yaml: key 'data.max_gap': Input should be greater than 0 (got -1)"),
    ({"path": "a.dat", "input": "u", "output": "y", "columns": []},
     "c.yaml: key 'data.columns': List should have at least 1 item after validation, not 0 "
     "(got [])"),
    ({"path": "a.csv", "format": "xls", "input": "u", "output": "y"},
     "c.yaml: key 'data.format': Input should be 'csv', 'dat', 'mat', 'xlsx', 'parquet', "
     "'mcap', 'tsv', 'txt', 'text', 'feather' or 'arrow' (got 'xls')"),
    # keys that exclude each other, or a value only the format's model knows is wrong
    ({"path": "a.csv", "input": "u", "output": "y", "time": "t", "sample_time": 0.5},
     "c.yaml: key 'data.sample_time': a sample time and a time column exclude each other; "
     "give one (got 0.5)"),
    ({"path": "a.xlsx", "input": "u", "output": "y", "time": "t", "time_zone": "Mars/Base"},
     "c.yaml: key 'data.time_zone': unknown time zone 'Mars/Base'; expected an IANA name such "
     "as Europe/Berlin or UTC (got 'Mars/Base')"),
    ({"path": "a.csv", "input": "u", "output": "y", "time": "t", "delimiter": "pipe"},
     "c.yaml: key 'data.delimiter': Input should be 'tab', 'semicolon', 'comma' or "
     "'whitespace' (got 'pipe')"),
])
def test_data_keys_at_config_load(section, expected):
    with pytest.raises(UserError) as exc:
        config_from_dict({"data": section}, source="c.yaml")
    assert exc.value.message == expected


def test_a_folder_is_checked_when_its_files_are_resolved(tmp_path):
    """The format of a folder's files is known only when they are listed: then it is
    checked, before any file is loaded."""
    (tmp_path / "run.dat").write_text("0 1 2\n1 1 2\n")
    cfg = config_from_dict({"data": {"path": str(tmp_path), "input": "u", "output": "y",
                                     "stamp": "header.stamp"}}, source="c.yaml")
    with pytest.raises(UserError) as exc:
        resolve_specs(cfg)
    assert exc.value.message == (
        "c.yaml: key 'data.stamp' does not apply to dat files (it is an option of: mcap); "
        f"the path matches {tmp_path / 'run.dat'}")


def test_load_record_rejects_a_key_of_another_format():
    data = DataConfig(path=MCAP, input={"topic": "/lamp/cmd", "field": "data"},
                      output={"topic": "/plate/temp", "field": "temperature.value"},
                      time="t")
    with pytest.raises(UserError) as exc:
        load_record(Path(MCAP), data)
    assert exc.value.message == (f"{MCAP}: key 'data.time' does not apply to mcap files "
                                 "(it is an option of: csv, dat, mat, xlsx, parquet)")


def test_format_choices_are_the_registry():
    schema = DataConfig.model_json_schema()["properties"]["format"]["anyOf"][0]
    assert schema["enum"] == list(NAMES)
    assert set(NAMES) == set(FORMATS) | {a for f in FORMATS.values() for a in f.aliases}


def test_cli_time_option_on_an_mcap_log_is_rejected():
    r = CliRunner().invoke(app, ["identify", MCAP, "--input", "/lamp/cmd:data",
                                 "--output", "/plate/temp:temperature.value", "--time", "t"])
    assert r.exit_code == 2
    assert r.stderr.strip() == (f"error: {MCAP}: --time does not apply to mcap files "
                                "(it is an option of: csv, dat, mat, xlsx, parquet)")


def _readme_rows() -> dict[str, list[str]]:
    """README table rows by their first cell (without backticks and aliases)."""
    text = (ROOT / "README.md").read_text()
    return {line.split("|")[1].split("(")[0].strip(" `"): [c.strip() for c in line.split("|")]
            for line in text.splitlines() if line.startswith("| `")}


def test_readme_tables_list_every_format_and_key():
    """The formats table names each format's suffixes, aliases and own keys (those beyond
    the keys every table takes); the keys table names each key's formats and option."""
    from pipeline.cli.data import DATA_OPTIONS, flag
    from pipeline.io.registry import formats_taking
    from pipeline.io.table import TableOptions

    rows = _readme_rows()
    shared = set(TableOptions.model_fields)
    for name, fmt in FORMATS.items():
        row = "|".join(rows[name])
        own = fmt.keys - shared if issubclass(fmt.options, TableOptions) else fmt.keys
        for word in (*fmt.suffixes, *fmt.aliases, *own):
            assert f"`{word}`" in row, (name, word)
    options = {name for name, _, _ in DATA_OPTIONS}
    for key in FORMAT_KEYS:
        cells = rows[key]
        assert cells[2] == ", ".join(formats_taking(key)), key
        assert (flag(key) in cells[3]) == (key in options), key
