"""The output folder (issue 13 items 2, 3, 9, 10, 11, 13): only the run's own files are
replaced, the staging folder lives inside the target (mount points), stale staging of a
killed run is removed, a bad target is one line before the batch, and modes follow the
umask or the replaced file."""

from __future__ import annotations

import errno
import json
import os
import time
from pathlib import Path

import polars as pl
import pytest
from typer.testing import CliRunner

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.cli.commands import app
from pipeline.config import folder_name
from pipeline.errors import UserError
from pipeline.files import check_writable, default_mode, write_atomic
from pipeline.models import ProcessModel
from pipeline.report import outdir
from pipeline.report.build import write_run
from pipeline.results import RunResult
from pipeline.synth import step_record
from tests.corpus import config, step_csv

runner = CliRunner()
PLANT = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 0.0})


@pytest.fixture(scope="module")
def run() -> RunResult:
    rec = step_record(PLANT, u0=0.0, changes=[(20.0, 1.0)], t_end=100.0, dt=0.5, y0=0.0,
                      noise=0.01, seed=1, name="plant")
    return RunResult([analyse(rec, AnalysisOptions(methods=("first_order",)))], config="t")


def _write(out: Path, run: RunResult, **kw) -> Path:
    return write_run(out, run, run.to_doc(), title="t", **kw)


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    yield
    os.umask(old)


# -- item 2: only the run's own outputs ---------------------------------------------------

@pytest.mark.parametrize("plots", ["summary", "none"])
def test_user_files_in_the_folder_and_in_plots_are_kept(tmp_path, run, plots):
    out = tmp_path / "out"
    (out / "plots").mkdir(parents=True)
    (out / "plots" / "mine.png").write_bytes(b"my own plot")
    (out / "notes.txt").write_text("mine")
    _write(out, run, plots_mode=plots)
    _write(out, run, plots_mode=plots)  # and again, over its own outputs
    assert (out / "plots" / "mine.png").read_bytes() == b"my own plot"
    assert (out / "notes.txt").read_text() == "mine"
    assert json.loads((out / "results.json").read_text())["records"][0]["name"] == "plant"
    ours = sorted(p.name for p in (out / "plots").iterdir() if p.name != "mine.png")
    assert (ours == ["plant_overview.png"]) == (plots == "summary") and (ours == []) == (
        plots == "none")


def test_an_earlier_runs_plots_go_with_it_the_users_stay(tmp_path, run):
    out = tmp_path / "out"
    _write(out, run, plots_mode="full")
    full = {p.name for p in (out / "plots").iterdir()}
    assert "plant_overview.png" in full and len(full) >= 3
    (out / "plots" / "mine.png").write_bytes(b"x")
    _write(out, run, plots_mode="summary")
    assert {p.name for p in (out / "plots").iterdir()} == {"plant_overview.png", "mine.png"}
    _write(out, run, markdown=False)  # no report.md, no plots: the old ones are not left
    assert not (out / "report.md").exists() and (out / "report.html").is_file()
    assert {p.name for p in (out / "plots").iterdir()} == {"mine.png"}


def test_a_users_report_md_in_a_folder_no_run_wrote_is_kept(tmp_path, run):
    """Issue 31: ``markdown: false`` into a folder with the user's own report.md (no
    manifest: no run wrote there) removed it. Only what a manifest lists goes; the twin:
    the run's own report.md of an earlier run still goes (above)."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").write_text("my notes")
    _write(out, run, markdown=False)
    assert (out / "report.md").read_text() == "my notes"
    assert "report.md" not in json.loads((out / outdir.MANIFEST).read_text())
    _write(out, run, markdown=False)  # and again: it is still not ours
    assert (out / "report.md").read_text() == "my notes"


def test_a_planted_manifest_removes_nothing_outside_plots(tmp_path, run):
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "victim.txt").write_text("keep")
    (out / "notes.txt").write_text("keep")
    (out / outdir.MANIFEST).write_text(json.dumps(["../victim.txt", "notes.txt",
                                                   "plots/../notes.txt"]))
    _write(out, run, plots_mode="none")
    assert (tmp_path / "victim.txt").read_text() == "keep"
    assert (out / "notes.txt").read_text() == "keep"


# -- item 10: the staging folder lives inside the target -----------------------------------

def test_a_mount_point_works(tmp_path, run, monkeypatch):
    """A rename that leaves the output folder fails as across filesystems (EXDEV), as on a
    Docker volume; the old code staged beside it and failed every time."""
    out = (tmp_path / "mnt").resolve()
    out.mkdir()
    (out / "report.html").write_text("old")
    real_replace, real_rename = os.replace, os.rename

    def inside(p) -> bool:
        return Path(os.path.abspath(p)).is_relative_to(out)

    def guard(real):
        def move(src, dst, *a, **kw):
            if inside(src) != inside(dst):
                raise OSError(errno.EXDEV, "Invalid cross-device link")
            return real(src, dst, *a, **kw)
        return move

    monkeypatch.setattr(os, "replace", guard(real_replace))
    monkeypatch.setattr(os, "rename", guard(real_rename))
    _write(out, run, plots_mode="summary")
    assert (out / "report.html").read_text() != "old"
    assert (out / "plots" / "plant_overview.png").is_file()
    assert not [p for p in out.iterdir() if ".tmp-" in p.name]
    assert [p.name for p in tmp_path.iterdir()] == ["mnt"]  # nothing staged beside it


def test_a_run_that_dies_before_the_swap_leaves_the_old_report(tmp_path, run, monkeypatch):
    out = tmp_path / "out"
    _write(out, run, plots_mode="summary")
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    real = Path.write_bytes

    def fail_on_html(self, data):
        if self.name == "report.html":
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", fail_on_html)
    with pytest.raises(UserError, match="No space left"):
        write_run(out, run, run.to_doc(), title="changed", plots_mode="summary")
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before


# -- item 9: stale staging of a killed run ------------------------------------------------

def test_stale_staging_of_a_dead_run_is_removed(tmp_path, run):
    out = tmp_path / "out"
    host = outdir.host_tag()
    dead = out / f"{outdir.STAGING}{host}-99999999-abcd_123"  # beyond any pid_max
    live = out / f"{outdir.STAGING}{host}-1-abcd_123"  # init: alive
    other = out / f"{outdir.STAGING}otherhost-99999999-abcd_123"  # not ours to judge
    for d in (dead, live, other):
        (d / "plots").mkdir(parents=True)
        (d / "report.html").write_text("<html>half")
    _write(out, run, plots_mode="none")
    assert not dead.exists() and live.is_dir() and other.is_dir()


def test_stale_staging_of_another_host_goes_by_its_age(tmp_path, run):
    """A CI container of a random host name on a shared mount: its killed run's staging is
    judged by age (a staging folder lives for seconds), a fresh one is left alone."""
    out = tmp_path / "out"
    old = out / f"{outdir.STAGING}ci-runner-7f3a-4242-abcd_123"
    fresh = out / f"{outdir.STAGING}ci-runner-9b1c-4343-abcd_123"
    for d in (old, fresh):
        (d / "plots").mkdir(parents=True)
        (d / "report.html").write_text("<html>half")
    hours_ago = time.time() - 2 * outdir.STALE_AGE
    os.utime(old, (hours_ago, hours_ago))
    _write(out, run, plots_mode="none")
    assert not old.exists() and fresh.is_dir()


def test_staging_names_its_host_and_pid(tmp_path, run, monkeypatch):
    seen = []
    real = outdir.tempfile.mkdtemp

    def spy(*a, **kw):
        seen.append(Path(real(*a, **kw)))
        return str(seen[-1])

    monkeypatch.setattr(outdir.tempfile, "mkdtemp", spy)
    _write(tmp_path / "out", run, plots_mode="none")
    m = outdir._STALE.fullmatch(seen[0].name)
    assert seen[0].parent == (tmp_path / "out").resolve()
    assert m and int(m["pid"]) == os.getpid() and m["host"] == outdir.host_tag()
    assert not seen[0].exists()


# -- item 3: name is a label --------------------------------------------------------------

@pytest.mark.parametrize("name,folder", [
    ("../../../x", "x"), ("/srv/x", "srv_x"), ("..", "run"), ("", "run"),
    ("Line 2 / oven", "Line_2_oven"), (".hidden", "hidden"), ("thermal", "thermal"),
    ("a\nb\x1b[31m", "a_b_31m"), ("Kühlung", "Kühlung"), ("x" * 300, "x" * 100),
])
def test_folder_name(name, folder):
    got = folder_name(name)
    if folder == name:  # a safe name is its own folder
        assert got == folder
    else:  # a changed one carries 8 hex digits of the name's hash
        assert got.startswith(folder + "-") and len(got) == len(folder) + 9
        assert all(c in "0123456789abcdef" for c in got[-8:])


def test_different_names_never_share_a_folder():
    names = ["a/b", "a b", "a_b", "..", "...", "", "run", "/srv/x", "srv_x", "x" * 300,
             "x" * 301]
    assert len({folder_name(n) for n in names}) == len(names)


@pytest.mark.parametrize("name,folder", [("../../../esc", folder_name("../../../esc")),
                                         ("/tmp/h13-abs-name", folder_name("/tmp/h13-abs-name"))])
def test_name_never_writes_outside_reports(tmp_path, monkeypatch, name, folder):
    work = tmp_path / "a" / "b" / "c"
    work.mkdir(parents=True)
    (work / "log.csv").write_text(step_csv())
    (work / "c.yaml").write_text(config("path: log.csv\ninput: u\noutput: y\ntime: time",
                                        name=json.dumps(name), extra="report: {plots: none}"))
    monkeypatch.chdir(work)
    r = runner.invoke(app, ["run", "c.yaml", "--workers", "1"])
    assert r.exit_code == 0, r.output
    assert (work / "reports" / folder / "report.html").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]
    assert not Path(name).exists() or Path(name).resolve().is_relative_to(work)
    html = (work / "reports" / folder / "report.html").read_text()
    assert f"System identification: {name}" in html.replace("&#34;", '"')


# -- item 11: a bad target is one line, before the batch ----------------------------------

def _cfg(d: Path) -> Path:
    (d / "log.csv").write_text(step_csv())
    (d / "c.yaml").write_text(config("path: log.csv\ninput: u\noutput: y\ntime: time"))
    return d / "c.yaml"


@pytest.mark.parametrize("extra,needle", [
    (["--out", "{d}/afile/sub"], "afile is a file, not a folder"),
    (["--out", "{d}/afile"], "is a file); expected a folder"),
    (["--out", "{d}/o", "--junit", "{d}/jdir"], "JUnit file (is a folder)"),
    (["--out", "{d}/o", "--junit", "{d}/afile/j.xml"], "afile is a file, not a folder"),
    (["--out", "{d}/o", "--history", "{d}/jdir"], "history (is a folder)"),
])
def test_bad_targets_are_one_line_before_the_batch(tmp_path, extra, needle, monkeypatch):
    c = _cfg(tmp_path)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "jdir").mkdir()
    import pipeline.run

    def no_batch(*a, **kw):
        raise AssertionError("the batch ran")

    monkeypatch.setattr(pipeline.run, "run_records", no_batch)
    r = runner.invoke(app, ["run", str(c), *[a.replace("{d}", str(tmp_path)) for a in extra]])
    assert r.exit_code == 2, r.output
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr, r.stderr
    assert not (tmp_path / "o").exists()
    assert (tmp_path / "afile").read_text() == "x"


def test_identify_out_under_a_file_is_one_line(tmp_path):
    (tmp_path / "log.csv").write_text(step_csv())
    (tmp_path / "afile").write_text("x")
    r = runner.invoke(app, ["identify", str(tmp_path / "log.csv"), "--input", "u", "--output",
                            "y", "--time", "time", "--method", "first_order", "--out",
                            str(tmp_path / "afile" / "sub")])
    assert r.exit_code == 2 and "afile is a file, not a folder" in r.stderr, r.output


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_unwritable_parent_is_one_line(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(UserError, match="is not writable"):
            check_writable(ro / "out", "report folder", folder=True)
    finally:
        ro.chmod(0o755)


def test_a_parent_that_cannot_hold_folders_is_one_line(tmp_path, run):
    """/proc refuses new folders even to root: the OSError is one line, not a traceback."""
    with pytest.raises(UserError, match="/proc/pipeline-x: cannot write the report"):
        _write(Path("/proc/pipeline-x"), run, plots_mode="none")


# -- item 13: modes -----------------------------------------------------------------------

def _mode(p: Path) -> int:
    return p.stat().st_mode & 0o777


@pytest.mark.parametrize("mask,file_mode,dir_mode", [(0o022, 0o644, 0o755),
                                                     (0o027, 0o640, 0o750)])
def test_new_outputs_get_the_umasks_mode(tmp_path, run, mask, file_mode, dir_mode):
    old = os.umask(mask)
    try:
        assert default_mode() == file_mode and default_mode(directory=True) == dir_mode
        out = tmp_path / "new" / "out"
        _write(out, run, plots_mode="summary")
        write_atomic(tmp_path / "junit.xml", b"<x/>", "JUnit file")
    finally:
        os.umask(old)
    assert _mode(out) == dir_mode and _mode(out.parent) == dir_mode
    assert _mode(out / "plots") == dir_mode
    for p in [*out.glob("*.*"), *out.glob("plots/*")]:
        assert _mode(p) == file_mode, p
    assert _mode(tmp_path / "junit.xml") == file_mode


def test_a_replaced_file_keeps_its_mode(tmp_path, run, umask022):
    out = tmp_path / "out"
    _write(out, run, plots_mode="summary")
    (out / "report.html").chmod(0o600)
    (out / "results.json").chmod(0o664)
    (out / "plots" / "plant_overview.png").chmod(0o640)
    (out / "plots").chmod(0o750)
    out.chmod(0o775)
    _write(out, run, plots_mode="summary")
    assert _mode(out / "report.html") == 0o600 and _mode(out / "results.json") == 0o664
    assert _mode(out / "plots" / "plant_overview.png") == 0o640
    assert _mode(out / "plots") == 0o750 and _mode(out) == 0o775
    assert _mode(out / "report.md") == 0o644
    j = tmp_path / "j.xml"
    j.write_text("old")
    j.chmod(0o660)
    write_atomic(j, b"<x/>", "JUnit file")
    assert _mode(j) == 0o660 and j.read_bytes() == b"<x/>"


def test_a_plots_link_is_never_written_through(tmp_path, run):
    """Issue 31: ``OUT/plots`` a link to a folder outside ``OUT`` made the run delete an
    earlier run's plot there and write its new plots through it. Now the run is refused
    before anything is written (exit 2 from the CLI, one line naming the link); the folder
    the link names and the report folder are untouched. The twin: a real ``plots`` folder
    is written as before (above)."""
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    _write(out, run, plots_mode="full")
    listed = json.loads((out / outdir.MANIFEST).read_text())
    elsewhere.mkdir()
    for name in listed:  # the link's folder holds files of the names the manifest lists
        if name.startswith("plots/"):
            (elsewhere / name.split("/", 1)[1]).write_bytes(b"not yours")
    before = {p.name: p.read_bytes() for p in elsewhere.iterdir()}
    report = (out / "report.html").read_bytes()
    for p in (out / "plots").iterdir():
        p.unlink()
    (out / "plots").rmdir()
    (out / "plots").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(UserError, match="is a link"):
        _write(out, run, plots_mode="summary")
    assert {p.name: p.read_bytes() for p in elsewhere.iterdir()} == before
    assert (out / "report.html").read_bytes() == report
    # a link made after the checks: publish refuses it too, nothing is staged or moved
    with pytest.raises(OSError, match="is a link"):
        outdir.publish(out, {"plots/a.png": b"x", "results.json": b"{}"})
    assert {p.name: p.read_bytes() for p in elsewhere.iterdir()} == before
    assert not [p for p in out.iterdir() if p.name.startswith(outdir.STAGING)]
    csv = tmp_path / "log.csv"
    csv.write_text(step_csv())
    res = runner.invoke(app, ["identify", str(csv), "--input", "u", "--output", "y",
                              "--time", "time", "--out", str(out)])
    assert res.exit_code == 2 and "is a link" in res.output, res.output
    assert {p.name: p.read_bytes() for p in elsewhere.iterdir()} == before


def _files(tag: str) -> dict[str, bytes]:
    doc = {"schema_version": "3", "pipeline_version": "0", "config": tag}
    return {"results.json": json.dumps(doc).encode(), "report.md": tag.encode(),
            "report.html": tag.encode(), f"plots/{tag}.png": b"png"}


@pytest.mark.parametrize("lock", [True, False])
def test_two_runs_onto_one_folder_publish_in_turn(tmp_path, monkeypatch, lock):
    """Run A's publish is slow (each move waits); run B publishes meanwhile. With the lock
    B waits and the folder is B's alone; without it (the must-fail twin, the lock taken
    away) the folder mixes the two runs, which is what the lock prevents."""
    import threading
    from contextlib import nullcontext

    from pipeline.report import outdir

    real_move, first_moved = outdir._move, threading.Event()

    def slow_move(src, dst):
        real_move(src, dst)
        if "A" in threading.current_thread().name:
            first_moved.set()
            time.sleep(0.15)
    monkeypatch.setattr(outdir, "_move", slow_move)
    if not lock:
        monkeypatch.setattr(outdir, "locked", lambda *a, **k: nullcontext())
    out = tmp_path / "out"
    a = threading.Thread(target=outdir.publish, args=(out, _files("A")), name="A")
    a.start()
    assert first_moved.wait(10)
    outdir.publish(out, _files("B"))
    a.join(10)
    tags = {(out / n).read_text() for n in ("report.md", "report.html")}
    tags |= {json.loads((out / "results.json").read_text())["config"]}
    tags |= {p.stem for p in (out / "plots").iterdir()}  # the plots a folder holds
    assert not any(outdir.STAGING in p.name for p in out.iterdir())
    assert tags == ({"B"} if lock else {"A", "B"})  # with the lock: A, then all of B


def test_four_real_runs_onto_one_folder_and_one_history(tmp_path):
    """Four ``pipeline run`` processes at once onto one ``--out`` and one ``--history``
    (issue 31): each exits 0, the folder holds one run's results.json, report.md and
    report.html (each config names its run; the reports carry the name in their title),
    and the history holds every run's rows, none lost."""
    import subprocess
    import sys

    from pipeline.synth.logs import write_synthetic_logs

    write_synthetic_logs(tmp_path / "logs", 2, seed=6, n_steps=2)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1]),
           "MPLBACKEND": "Agg"}
    procs = []
    for k in range(4):
        (tmp_path / f"night{k}.yaml").write_text(
            f"name: night{k}\ndata: {{path: logs, input: u, output: y, time: time}}\n"
            "methods: [first_order]\n")
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "pipeline", "run", f"night{k}.yaml", "--out", "out",
             "--workers", "1", "--history", "h.parquet", "-q"], cwd=tmp_path, env=env,
            stderr=subprocess.PIPE))
    for p in procs:
        assert p.wait(timeout=120) == 0, p.stderr.read().decode()
    out = tmp_path / "out"
    run = json.loads((out / "results.json").read_text())["config"]
    name = Path(run).stem
    assert name in {f"night{k}" for k in range(4)}
    for report in ("report.md", "report.html"):
        text = (out / report).read_text()
        assert f"System identification: {name}" in text
        assert not any(f"System identification: night{k}" in text
                       for k in range(4) if f"night{k}" != name)
    history = pl.read_parquet(tmp_path / "h.parquet")
    per_run = history.group_by("time").len()
    assert per_run.height == 4 and per_run["len"].n_unique() == 1, per_run  # none lost
    assert history["record"].n_unique() == 2
    assert not any(p.name.startswith(".pipeline.tmp-") for p in out.iterdir())
