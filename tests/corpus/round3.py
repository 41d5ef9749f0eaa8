"""Corpus rows for hardening round 3 (issue 31): an output never replaces an input, a
config key given twice, baselines that would switch the gate off, a ``plots`` link out of
the report folder, a user's report.md, damaged MCAP chunks and stamps that jump back,
damaged, empty and NUL-filled files of every format. Symbolic links to the run's inputs
and outputs and links in data folders: :mod:`tests.corpus.round3_links`.

Each refusal is one line naming the file, exit 2, before the batch (nothing written), the
named files byte-equal; each has a twin that must stay working (exit 0: an earlier JUnit
file of ours is replaced, a YAML merge may override what it merges, a baseline of numbers
gates, a crash-cut MCAP log without damage is read whole).
"""

from __future__ import annotations

import io
import json
import tempfile
from pathlib import Path

import polars as pl

from pipeline.report.junit import OUR_ROOT
from pipeline.report.outdir import MANIFEST
from tests.corpus import Hostile, config, step_csv

LOG = step_csv(n=200)  # one step at t = 20 s: a fit in a tenth of a second
CFG = config("path: log.csv\ninput: u\noutput: y\ntime: time", extra="report: {plots: none}\n")
FILES = {"c.yaml": CFG, "log.csv": LOG}
RUN = ("run", "c.yaml", "--out", "out", "--workers", "1")
INPUTS = ("c.yaml", "log.csv")


def no_report(d: Path) -> None:
    assert not (d / "out").exists(), "a refused run wrote a report"


def _results(d: Path, out: str = "out") -> dict:
    return json.loads((d / out / "results.json").read_text(encoding="utf-8"))


# -- an output never replaces an input (the config, a log, the baseline, each other) ------


def _baseline(K: float = 2.0, recommended: float | None = None) -> str:
    """A baseline of this run's config: first_order of record 'log' with gain ``K``
    (json writes nan and inf as NaN and Infinity, and reads them back); ``recommended``:
    the record's recommended model too, with that gain."""
    params = {"K": K, "T": 5.0, "delay": 0.0}
    record = {"name": "log", "source": "log.csv", "status": "ok",
              "fits": [{"method": "first_order", "event": 0, "status": "ok",
                        "structure": "first_order", "params": params}]}
    if recommended is not None:
        record["recommended"] = {"method": "first_order", "event": 0,
                                 "structure": "first_order",
                                 "params": {**params, "K": recommended}}
    return json.dumps({"schema_version": "2", "pipeline_version": "0.1", "config": "c.yaml",
                       "records": [record]})


#: a JUnit file an earlier run of ours wrote (its root element is what marks it ours)
EARLIER_JUNIT = ("<?xml version='1.0' encoding='utf-8'?>\n" + OUR_ROOT.decode()
                 + '" tests="1" failures="0" errors="0" earlier="yes"></testsuites>\n')


def _refused(kind: str, option: tuple[str, ...], needle: str, *, extra=None,
             keep: tuple[str, ...] = INPUTS) -> Hostile:
    return Hostile(kind, (*RUN, *option), 2, files={**FILES, **(extra or {})},
                   stderr=(needle,), keep=keep, max_lines=1, check=no_report)


def _junit_replaced(d: Path) -> None:
    text = (d / "j.xml").read_text(encoding="utf-8")
    assert text.count("<testsuites") == 1 and 'earlier="yes"' not in text, text[:200]
    assert (d / "out" / "report.html").is_file()


CASES = [
    _refused("junit_names_the_config", ("--junit", "c.yaml"),
             "c.yaml: the JUnit file would replace the config (c.yaml); give another path"),
    _refused("junit_names_the_log", ("--junit", "log.csv"),
             "log.csv: the JUnit file would replace the log of record 'log'"),
    _refused("junit_names_the_baseline", ("--baseline", "b.json", "--junit", "b.json"),
             "b.json: the JUnit file would replace the baseline (b.json)",
             extra={"b.json": _baseline()}, keep=(*INPUTS, "b.json")),
    _refused("history_names_the_config", ("--history", "c.yaml"),
             "c.yaml: the history would replace the config (c.yaml)"),
    _refused("history_names_the_log", ("--history", "log.csv"),
             "log.csv: the history would replace the log of record 'log'"),
    _refused("history_names_the_baseline", ("--baseline", "b.json", "--history", "b.json"),
             "b.json: the history would replace the baseline (b.json)",
             extra={"b.json": _baseline()}, keep=(*INPUTS, "b.json")),
    _refused("junit_and_history_one_path", ("--junit", "same.out", "--history", "same.out"),
             "same.out: the history would replace the JUnit file (same.out)"),
    _refused("junit_onto_a_foreign_xml_file", ("--junit", "notes.xml"),
             "notes.xml: exists and is not a JUnit file pipeline wrote",
             extra={"notes.xml": "<notes>mine</notes>\n"}, keep=(*INPUTS, "notes.xml")),
    _refused("junit_onto_an_empty_file", ("--junit", "j.xml"),
             "j.xml: exists and is not a JUnit file pipeline wrote",
             extra={"j.xml": ""}, keep=(*INPUTS, "j.xml")),
    _refused("junit_onto_dev_null", ("--junit", "/dev/null"),
             "/dev/null: a device, not a regular file; cannot write the JUnit file there"),
    _refused("history_onto_dev_null", ("--history", "/dev/null"),
             "/dev/null: a device, not a regular file; cannot write the history there"),
    # the twin: a JUnit file of an earlier run of ours is replaced
    Hostile("junit_onto_an_earlier_junit_file", (*RUN, "--junit", "j.xml"), 0,
            files={**FILES, "j.xml": EARLIER_JUNIT}, keep=INPUTS, max_lines=0,
            check=_junit_replaced),
]

# -- an output never replaces the report's own files (refused before the batch) ----------


def _beside_the_report(d: Path) -> None:
    assert _results(d)["records"][0]["status"] == "ok"
    assert (d / "out" / "j.xml").read_text(encoding="utf-8").count("<testsuites") == 1
    assert (d / "out" / "h.parquet").stat().st_size > 0


CASES += [
    _refused(f"{what}_names_the_reports_{name.strip('.').replace('-', '_').replace('.', '_')}",
             (f"--{what}", f"out/{name}"),
             f"out/{name}: is the report's own {shown} in out, which each run replaces")
    for what in ("junit", "history")
    for name, shown in (("results.json", "results.json"), ("report.md", "report.md"),
                        ("report.html", "report.html"), (MANIFEST, MANIFEST),
                        ("plots/h.out", "plots folder"))
]
CASES += [
    # the twin: a JUnit file and a history of other names in the report folder are kept
    Hostile("junit_and_history_beside_the_report",
            (*RUN, "--junit", "out/j.xml", "--history", "out/h.parquet"), 0, files=FILES,
            keep=INPUTS, max_lines=0, check=_beside_the_report),
]

# -- a config key given twice: refused, naming the key and both lines ---------------------

TWICE = ("name: x\ndata:\n  path: log.csv\n  input: u\n  output: y\n  input: v\n"
         "methods: [first_order]\n")
MERGED = ("name: x\ndata:\n  <<: {path: log.csv, input: u, output: v, time: time}\n"
          "  output: y\nmethods: [first_order]\nreport: {plots: none}\n")


def _merged(d: Path) -> None:
    rec = _results(d)["records"][0]
    assert rec["status"] == "ok" and rec["fits"][0]["status"] == "ok"
    assert abs(rec["fits"][0]["params"]["K"] / 2.0 - 1) < 0.05, rec["fits"][0]["params"]


def _twice(kind: str, text: str, needle: str, *options: str) -> Hostile:
    return Hostile(kind, (*RUN, *options), 2, files={"c.yaml": text, "log.csv": LOG},
                   stderr=(needle,), keep=INPUTS, max_lines=1, check=no_report)


CASES += [
    _twice("config_data_key_given_twice", TWICE,
           "c.yaml: line 6: not valid YAML (key 'input' given twice (first at line 4))"),
    _twice("config_data_key_given_twice_check", TWICE,
           "key 'input' given twice (first at line 4)", "--check"),
    _twice("config_top_level_key_given_twice",
           TWICE.replace("  input: v\n", "  time: time\n") + "methods: all\n",
           "c.yaml: line 8: not valid YAML (key 'methods' given twice (first at line 7))"),
    _twice("config_name_given_twice", "name: a\n" + TWICE.replace("  input: v\n", ""),
           "c.yaml: line 2: not valid YAML (key 'name' given twice (first at line 1))"),
    _twice("config_alias_of_a_key_given_twice",
           "name: x\n&k methods: all\n*k : [first_order]\n"
           "data: {path: log.csv, input: u, output: y}\n",
           "key 'methods' given twice"),
    # the twin: a YAML merge may still override what it merges (output v -> y)
    Hostile("config_merge_overrides_what_it_merges", RUN, 0,
            files={"c.yaml": MERGED, "log.csv": LOG}, keep=INPUTS, max_lines=0,
            check=_merged),
]

# -- baselines that would switch the gate off, or are no file at all ----------------------


def _bad_baseline(kind: str, content: str | bytes, needle: str) -> Hostile:
    return _refused(kind, ("--baseline", "b.json"), needle, extra={"b.json": content},
                    keep=(*INPUTS, "b.json"))


def _regressed(d: Path) -> None:
    md = (d / "out" / "report.md").read_text(encoding="utf-8")
    assert "## Regressions against the baseline" in md


CASES += [
    _bad_baseline("baseline_fit_parameter_nan", _baseline(K=float("nan")),
                  "b.json: record 'log', fit 'first_order' (event 0): parameter 'K' is nan"),
    _bad_baseline("baseline_fit_parameter_inf", _baseline(K=float("inf")),
                  "parameter 'K' is inf; a baseline's parameters must be numbers"),
    _bad_baseline("baseline_recommended_parameter_nan",
                  _baseline(recommended=float("nan")),
                  "b.json: record 'log', the recommended model: parameter 'K' is nan"),
    _bad_baseline("baseline_truncated_json", _baseline()[:len(_baseline()) // 2],
                  "b.json: line 1: not valid JSON"),
    _bad_baseline("baseline_empty_file", "", "b.json: line 1: not valid JSON"),
    _bad_baseline("baseline_nul_bytes", b"\0" * 4096, "b.json: line 1: not valid JSON"),
    _refused("baseline_dev_zero", ("--baseline", "/dev/zero"),
             "/dev/zero: a device, not a regular file; expected the results file"),
    _refused("baseline_is_a_folder", ("--baseline", "bdir"),
             "bdir: cannot read the results file", extra={"bdir/results.json": _baseline()},
             keep=(*INPUTS, "bdir/results.json")),
    Hostile("baseline_accept_nan_refused", ("baseline", "accept", "r.json", "--to", "b.json"),
            2, files={"r.json": _baseline(K=float("nan"))}, keep=("r.json",), max_lines=1,
            stderr=("r.json: record 'log', fit 'first_order' (event 0): parameter 'K' is nan",),
            check=lambda d: not (d / "b.json").exists()
            or (_ for _ in ()).throw(AssertionError("b.json written"))),
    # the twin: the same baseline with numbers gates (tonight's gain is twice its K: exit 1)
    Hostile("baseline_of_numbers_still_gates", (*RUN, "--baseline", "b.json"), 1,
            files={**FILES, "b.json": _baseline(K=1.0, recommended=1.0)},
            keep=(*INPUTS, "b.json"), max_lines=0, check=_regressed),
]

# -- the report folder: a plots link out of it, a user's report.md ------------------------


def _elsewhere_untouched(d: Path) -> None:
    assert sorted(p.name for p in (d / "elsewhere").iterdir()) == ["mine.png"]
    assert sorted(p.name for p in (d / "out").iterdir()) == ["plots"]
    assert (d / "out" / "plots").is_symlink()


def _users_report_md_kept(d: Path) -> None:
    assert "report.md" not in json.loads((d / "out" / MANIFEST).read_text(encoding="utf-8"))
    assert (d / "out" / "report.html").is_file()


def _no_report_md(d: Path) -> None:
    assert not (d / "out" / "report.md").exists() and (d / "out" / "report.html").is_file()


NO_MARKDOWN = CFG.replace("report: {plots: none}", "report: {plots: none, markdown: false}")
PLOTS_LINK = "out/plots: cannot write the report's plots (is a link to ../elsewhere)"

CASES += [
    *(Hostile(f"out_plots_link_outside_{plots}", RUN, 2,
              files={"c.yaml": CFG.replace("plots: none", f"plots: {plots}"), "log.csv": LOG,
                     "elsewhere/mine.png": b"\x89PNG mine"},
              links={"out/plots": "../elsewhere"}, keep=(*INPUTS, "elsewhere/mine.png"),
              stderr=(PLOTS_LINK,), max_lines=1, check=_elsewhere_untouched)
      for plots in ("none", "summary")),
    Hostile("identify_out_plots_link_outside",
            ("identify", "log.csv", "--input", "u", "--output", "y", "--time", "time",
             "--method", "first_order", "--out", "out"), 2,
            files={"log.csv": LOG, "elsewhere/mine.png": b"\x89PNG mine"},
            links={"out/plots": "../elsewhere"}, keep=("log.csv", "elsewhere/mine.png"),
            stderr=(PLOTS_LINK,), max_lines=1, check=_elsewhere_untouched),
    Hostile("out_markdown_false_keeps_users_report_md", RUN, 0,
            files={"c.yaml": NO_MARKDOWN, "log.csv": LOG, "out/report.md": "my notes\n"},
            keep=(*INPUTS, "out/report.md"), max_lines=0, check=_users_report_md_kept),
    # the twin: markdown false into an empty folder writes no report.md
    Hostile("out_markdown_false_writes_no_report_md", RUN, 0,
            files={"c.yaml": NO_MARKDOWN, "log.csv": LOG}, keep=INPUTS, max_lines=0,
            check=_no_report_md),
]

# -- MCAP: a damaged chunk in a crash-cut log, stamps that jump back ----------------------


def _mcap_logs() -> dict[str, bytes]:
    """The MCAP logs of tests/test_mcap.py's builders (K = 2.5, T = 7 s, 701 samples of
    0.1 s): ``cut`` a log cut off by a crash (no summary: read by the sequential scan),
    ``flipped`` the same with one digit of one value changed inside a middle chunk (its
    CRC fails), ``two`` stamps that restart 30 s back halfway, ``late`` stamps up to a
    quarter of a second out of order."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType

    import tests.test_mcap as tm

    rec = tm.truth()
    with tempfile.TemporaryDirectory() as tmp:
        path = tm.json_file(Path(tmp), rec, chunk_size=4096,
                            compression=CompressionType.NONE)
        with open(path, "rb") as f:
            chunks = make_reader(f).get_summary().chunk_indexes
        cut = path.read_bytes()[:tm._summary_start(path)]
        bad = chunks[len(chunks) // 2]
        flipped = bytearray(cut)
        at = flipped.index(b'{"data": ', bad.chunk_start_offset + 100) + len(b'{"data": ')
        digit = next(i for i in range(at + 2, flipped.index(b"}", at))
                     if flipped[i:i + 1].isdigit())
        flipped[digit] = ord("7") if flipped[digit] != ord("7") else ord("3")
        two = tm.write_json(Path(tmp) / "two.mcap",
                            tm._stamped_events(rec, (1, 20), reset_at=35.0)).read_bytes()
        late = tm.write_json(Path(tmp) / "late.mcap",
                             tm._stamped_events(rec, (1, 250))).read_bytes()
    return {"cut": cut, "flipped": bytes(flipped), "two": two, "late": late}


MCAP = _mcap_logs()
MCAP_CFG = ("name: m\ndata:\n  path: log.mcap\n  input: {topic: /u, field: data}\n"
            "  output: {topic: /y, field: data}\n{stamp}methods: [first_order]\n"
            "report: {plots: none}\n")
STAMPED = MCAP_CFG.replace("{stamp}", "  stamp: header.stamp\n")
LOG_TIME = MCAP_CFG.replace("{stamp}", "")


def _mcap_read(n: int | None, *, crc: bool, note: str | None = None):
    """A check: the record has ``n`` samples (None: fewer than 701 but most), a note of
    a chunk whose CRC failed (``crc``) or none, and a note holding ``note``."""
    def check(d: Path) -> None:
        rec = _results(d)["records"][0]
        assert rec["status"] == "ok", rec["error"]
        if n is None:
            assert 0.7 * 701 < rec["n_samples"] < 701, rec["n_samples"]
        else:
            assert rec["n_samples"] == n, rec["n_samples"]
        assert any("CRC" in x for x in rec["notes"]) == crc, rec["notes"]
        assert note is None or any(note in x for x in rec["notes"]), rec["notes"]
    return check


CASES += [
    Hostile("mcap_damaged_chunk_of_a_crash_cut_log_skipped", RUN, 0,
            files={"c.yaml": LOG_TIME, "log.mcap": MCAP["flipped"]}, keep=("log.mcap",),
            check=_mcap_read(None, crc=True, note="sequential scan")),
    Hostile("mcap_crash_cut_log_read_whole", RUN, 0,
            files={"c.yaml": LOG_TIME, "log.mcap": MCAP["cut"]}, keep=("log.mcap",),
            check=_mcap_read(701, crc=False, note="sequential scan")),
    Hostile("mcap_stamps_jump_back_refused", RUN, 2,
            files={"c.yaml": STAMPED, "log.mcap": MCAP["two"]}, keep=("log.mcap",),
            stderr=("log.mcap: input /u:data: its header stamps jump back by 29.9 s at "
                    "message 351 of 701 finite ones", "omit stamp")),
    Hostile("mcap_stamps_jump_back_by_log_time", RUN, 0,
            files={"c.yaml": LOG_TIME, "log.mcap": MCAP["two"]}, keep=("log.mcap",),
            check=_mcap_read(None, crc=False)),
    Hostile("mcap_stamps_a_little_late_sorted", RUN, 0,
            files={"c.yaml": STAMPED, "log.mcap": MCAP["late"]}, keep=("log.mcap",),
            check=_mcap_read(701, crc=False, note="arrived behind a later header stamp")),
    Hostile("mcap_cut_after_40_bytes", RUN, 2,
            files={"c.yaml": LOG_TIME, "log.mcap": MCAP["cut"][:40]}, keep=("log.mcap",),
            stderr=("log.mcap: cannot read input /u:data and output /y:data: the file is "
                    "truncated or damaged",)),
]

# -- damaged, empty and NUL-filled files: one line naming the file, for every format ------


def _parquet() -> bytes:
    buf = io.BytesIO()
    pl.read_csv(io.StringIO(LOG)).write_parquet(buf)
    return buf.getvalue()


PARQUET = _parquet()
NOT_PARQUET = "not a readable Parquet or Arrow file (parquet: File out of specification"
DAMAGED = {  # name: (bytes, what stderr says)
    "parquet_cut_in_half": (PARQUET[:len(PARQUET) // 2], NOT_PARQUET),
    "parquet_end_magic_damaged": (PARQUET[:-4] + b"XXXX", NOT_PARQUET),
    "parquet_footer_length_damaged": (PARQUET[:-8] + b"\xff\xff\xff\x7f" + PARQUET[-4:],
                                      "The footer size must be smaller or equal"),
    "parquet_metadata_zeroed": (PARQUET[:4] + bytes(len(PARQUET) - 8) + PARQUET[-4:],
                                NOT_PARQUET),
    "parquet_magic_only": (b"PAR1", NOT_PARQUET),
}
EMPTY = {  # suffix: what stderr says of an empty file, of a file of NUL bytes
    "csv": ("the file is empty", "a binary file, not text"),
    "tsv": ("the file is empty", "a binary file, not text"),
    "dat": ("the file is empty", "a binary file, not text"),
    "mat": ("not a readable MAT-file", "not a readable MAT-file"),
    "xlsx": ("not a readable workbook", "not a readable workbook"),
    "parquet": ("neither Parquet nor Arrow IPC (it starts b'')",
                "neither Parquet nor Arrow IPC (it starts b'\\x00"),
    "feather": ("neither Parquet nor Arrow IPC", "neither Parquet nor Arrow IPC"),
    "arrow": ("neither Parquet nor Arrow IPC", "neither Parquet nor Arrow IPC"),
    "mcap": ("not an MCAP file", "not an MCAP file"),
}


def _identify(name: str) -> tuple[str, ...]:
    signals = (("--input", "/u:data", "--output", "/y:data") if name.endswith(".mcap")
               else ("--input", "u", "--output", "y", "--time", "time"))
    return ("identify", name, *signals, "--method", "first_order", "--json")


CASES += [
    *(Hostile(kind, _identify("log.parquet"), 2, files={"log.parquet": data},
              keep=("log.parquet",), stderr=("log.parquet: ", says), max_lines=1)
      for kind, (data, says) in DAMAGED.items()),
    *(Hostile(f"{suffix}_empty_file", _identify(f"log.{suffix}"), 2,
              files={f"log.{suffix}": b""}, keep=(f"log.{suffix}",),
              stderr=(f"log.{suffix}: {empty}",), max_lines=1)
      for suffix, (empty, _) in EMPTY.items()),
    *(Hostile(f"{suffix}_nul_bytes", _identify(f"log.{suffix}"), 2,
              files={f"log.{suffix}": b"\0" * 4096}, keep=(f"log.{suffix}",),
              stderr=(f"log.{suffix}: {nul}",), max_lines=1)
      for suffix, (_, nul) in EMPTY.items()),
    # the twin: the undamaged file identifies
    Hostile("parquet_undamaged_identifies", _identify("log.parquet"), 0,
            files={"log.parquet": PARQUET}, keep=("log.parquet",), max_lines=0),
]
