"""The one orchestration path: which records a config names, load -> analyse each, and a
run's outputs (results.json, reports, baseline gate, history, JUnit).

* :func:`run_config` - ``pipeline run``: a config from YAML to reports;
* :func:`identify_file` - ``pipeline identify``: one file with data and analysis options;
* :func:`process_record` - the per-record job the batch layer ships to processes or a
  Dask cluster: a picklable :class:`RecordSpec` and the :class:`~pipeline.config.RunConfig`
  in, a :class:`~pipeline.results.RecordResult` out; it never raises for a bad record
  (the failure travels in the result).

Both commands end in :func:`pipeline.analysis.analyse` with options built by
:func:`analysis_options`, so they give the same fits for the same file.
"""

from __future__ import annotations

import functools
import os
import time
from contextlib import ExitStack
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import polars as pl

from . import memory, report  # report's names load on first use (matplotlib, Jinja2)
from .analysis import AnalysisOptions, analyse
from .batch import (
    Stages,
    check_executor,
    lazy_pool,
    local_pool,
    parallel_map,
    run_records,
    show_progress,
)
from .config import DataConfig, RunConfig, load_config
from .errors import ExitCode, UserError
from .files import check_writable, refuse_input, same_file, through_link
from .gate import (
    Comparison,
    Tolerances,
    append_history,
    compare,
    history_lock,
    history_rows,
    load_baseline,
    load_history,
)
from .grading import record_verdict
from .io import check_file, dataset, fetch, files_named, load_record
from .log import logger
from .parallel import Workers
from .record import Record
from .results import RecordResult, RunResult, fit_times, results_json
from .schema import ResultsDoc
from .segmentation import SegmentOptions

log = logger(__name__)


@dataclass(frozen=True)
class RecordSpec:
    """One record to process: a file (``path``) or a registry dataset (``dataset``)."""

    name: str
    path: str
    dataset: str | None = None


@dataclass(frozen=True)
class Outcome:
    """What a run did: its exit code (:class:`~pipeline.errors.ExitCode`), where the
    reports are, the results and the lines to tell the user."""

    exit_code: int
    out_dir: Path | None
    run: RunResult
    messages: list[str] = field(default_factory=list)


def now_iso() -> str:
    """The run's creation time, UTC, to the microsecond (two runs never share it)."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


# -- options -----------------------------------------------------------------------------

def analysis_options(cfg: RunConfig) -> AnalysisOptions:
    """The analysis options of a config (the ``identify`` command builds the same)."""
    events = cfg.identification.events
    return AnalysisOptions(
        segmentation=SegmentOptions(**cfg.segmentation.model_dump()),
        events=events if events == "all" else tuple(events),
        methods=cfg.methods if cfg.methods == "all" else tuple(cfg.methods),
        refine=cfg.identification.refine_options(),
        consistency=cfg.consistency,
        tuning=cfg.tuning.options(),
    )


# -- resolving what to process -----------------------------------------------------------

def resolve_specs(cfg: RunConfig) -> list[RecordSpec]:
    """The records a config names; a path that matches nothing, or a ``data:`` key that
    does not apply to a file's format, is a :class:`UserError`.

    Every path is absolute (relative ones are taken from the config file's folder, here,
    in the client): a spec may be processed by a Dask worker started in another folder.
    """
    d = cfg.data
    if d.dataset:
        return [RecordSpec(name=d.dataset, path=str(Path(fetch(d.dataset)).absolute()),
                           dataset=d.dataset)]
    patterns = [d.path] if d.path else list(d.paths or [])
    base = Path(cfg.base_dir).absolute()
    files: list[Path] = []
    for pat in patterns:
        found = files_named(pat, base)
        if not found:
            raise UserError(f"{cfg.source}: key 'data.path': {pat!r} matches no file")
        files.extend(found)
    if len(files) == 1 and not files[0].is_file():
        raise UserError(f"{files[0]}: file not found")
    for f in files:
        check_file(d, f, cfg.source)  # a key of another format: the config is wrong
    names = _unique_names(files)
    return [RecordSpec(name=n, path=str(f)) for n, f in zip(names, files, strict=True)]


def _unique_names(files: list[Path]) -> list[str]:
    """File stems, or paths relative to the files' common folder where stems repeat, with
    a counter where even those repeat (the same file listed twice)."""
    stems = [f.stem for f in files]
    if len(set(stems)) == len(stems):
        return stems
    root = Path(os.path.commonpath([str(f.resolve().parent) for f in files]))
    rel = [f.resolve().relative_to(root).as_posix() for f in files]
    bare = [r.rsplit(".", 1)[0] for r in rel]
    distinct = {b: {r for r, b2 in zip(rel, bare, strict=True) if b2 == b} for b in bare}
    names = [b if len(distinct[b]) == 1 else r for r, b in zip(rel, bare, strict=True)]
    seen: dict[str, int] = {}
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}#{seen[n]}")
    return out


def effective_data(cfg: RunConfig, spec: RecordSpec) -> DataConfig:
    """The data section for one record; a dataset's registry entry fills what is unset."""
    d = cfg.data
    if not spec.dataset:
        return d
    ds = dataset(spec.dataset)
    fill = {"format": ds.format, "columns": ds.columns, "input": ds.input, "output": ds.output,
            "time": ds.time, "units": ds.units or None, "initial_input": ds.initial_input}
    return d.model_copy(update={k: v for k, v in fill.items() if getattr(d, k) is None})


# -- one record --------------------------------------------------------------------------

def analysed(record: Record, options: AnalysisOptions, name: str | None = None,
             workers: Workers | None = None) -> RecordResult:
    """:func:`pipeline.analysis.analyse`, then the C heap's freed pages handed back
    (:func:`pipeline.memory.release`): a long record's analysis frees thousands of
    window-sized arrays scattered through the heap, which the next stage (a report, the
    next record in a worker) could not reuse for its record-long arrays. ``workers``: for
    a long record's fits (:mod:`pipeline.parallel`)."""
    memory.reserve_blas_buffers()
    res = analyse(record, options, name=name, workers=workers)
    memory.release()
    return res


def process_record(spec: RecordSpec, cfg: RunConfig, workers: Workers | None = None
                   ) -> RecordResult:
    """Load and analyse one record; a bad record comes back with ``error`` set.
    ``workers``: for its fits, when the batch is this one record (:func:`_run_config`)."""
    try:
        log.info("%s: loading %s", spec.name, spec.path, extra={"stage": "load"})
        t0 = time.perf_counter()
        record = load_record(Path(spec.path), effective_data(cfg, spec), name=spec.name)
        log.info("%s: loaded %d samples in %.2f s; analysing", spec.name, record.n_samples,
                 time.perf_counter() - t0, extra={"stage": "analyse"})
        return analysed(record, analysis_options(cfg), name=spec.name, workers=workers)
    except UserError as exc:
        return RecordResult(name=spec.name, source=spec.path, error=exc.message)


def identify_file(path: Path, data: DataConfig, options: AnalysisOptions, *,
                  out_dir: Path | None = None, created: str | None = None,
                  workers: int | None = 1) -> RunResult:
    """``pipeline identify``: one file, analysed; reports written when ``out_dir`` is set.
    ``workers``: processes for a long record's fits (None: the cores; started only when
    the record has enough to fit, :mod:`pipeline.parallel`).

    A record that cannot be analysed is a :class:`UserError` (a single file has nothing
    else to report).
    """
    if out_dir is not None:
        report.check_target(out_dir)
    t0 = time.perf_counter()
    record = load_record(path, data)
    t1 = time.perf_counter()
    log.info("%s: loaded %d samples in %.2f s; analysing", record.name, record.n_samples,
             t1 - t0, extra={"stage": "load"})
    with lazy_pool(workers) as pool:
        res = analysed(record, options, workers=pool)
    if res.error:
        raise UserError(res.error)
    log.info("%s: %d event(s), %d fit(s) in %.2f s", record.name, len(res.events),
             len(res.fits), time.perf_counter() - t1, extra={"stage": "analyse"})
    run = RunResult([res], config=f"identify {path}", created=created or now_iso())
    if out_dir is not None:
        t2 = time.perf_counter()
        report.write_run(out_dir, run, run.to_doc(), title=f"Identification of {record.name}")
        log.info("%s: reports written in %.2f s", record.name, time.perf_counter() - t2,
                 extra={"stage": "report"})
    return run


def identify_json(path: Path, data: DataConfig, options: AnalysisOptions, *,
                  out_dir: Path | None = None, workers: int | None = 1) -> str:
    """``pipeline identify --json``: :func:`identify_file`'s results.json text, made once
    the record's arrays and the fits are dropped (the document alone is kept: at 10 M
    samples and 2000 events the text and its making are 1.4x the arrays)."""
    doc = identify_file(path, data, options, out_dir=out_dir, workers=workers).to_doc()
    return results_json(doc)


# -- a config ----------------------------------------------------------------------------

def run_config(config: str | os.PathLike | RunConfig, **options) -> Outcome:
    """Run a config end to end: every record, one report, the optional gate and history.

    Keywords: ``out_dir``, ``workers``, ``executor``, ``scheduler``, ``baseline``,
    ``junit``, ``history``, ``progress``, ``created`` and ``tolerances`` (a
    :class:`pipeline.gate.Tolerances`, defaults when None). Exit codes: 0 done, 1 a
    regression against ``baseline``, 3 some records failed, 2 all records failed (the
    reports, JUnit file and history row are written all the same). The report folder is
    ``out_dir``, else :meth:`RunConfig.report_folder`; it and the JUnit and history files
    are checked before the batch. User errors raise :class:`UserError`.

    The local process pool and the progress bars live in one :class:`~contextlib.ExitStack`
    around the run: the pool that ran the records draws the report's plots (no second
    pool), and an exception (SIGTERM included, :mod:`pipeline.batch.interrupt`) ends its workers.
    """
    with ExitStack() as stack:
        return _run_config(config, stack, **options)


def _run_config(config: str | os.PathLike | RunConfig, stack: ExitStack, *,
                out_dir: Path | None = None, workers: int | None = None,
                executor: str = "local", scheduler: str | None = None,
                baseline: Path | None = None, junit: Path | None = None,
                history: Path | None = None, progress: bool | None = None,
                created: str | None = None, tolerances: Tolerances | None = None) -> Outcome:
    started = time.perf_counter()  # the JUnit file's time
    cfg = config if isinstance(config, RunConfig) else load_config(config)
    plan = _plan(cfg, out_dir, executor, baseline, junit, history)
    pool = stack.enter_context(local_pool(workers if executor == "local" else 1,
                                          len(plan.specs), draws=cfg.report.plots != "none"))
    job = process_record
    if executor == "local" and len(plan.specs) == 1:  # one record: its fits spread instead
        fits_pool = stack.enter_context(lazy_pool(workers))
        job = functools.partial(process_record, workers=fits_pool) if fits_pool else job
    records = run_records(plan.specs, cfg, job, workers=workers, executor=executor,
                          scheduler=scheduler, progress=progress, pool=pool)
    stages = stack.enter_context(Stages(show_progress(progress)))
    # every record failing still writes the reports, the JUnit file and the history (CI
    # sees the failures), and exits 2
    run = RunResult(records, config=cfg.source, created=created or now_iso())
    doc = run.to_doc()
    comparison = None if plan.base_doc is None else compare(
        doc, plan.base_doc, tolerances or Tolerances())
    run_time = datetime.fromisoformat(run.created)
    extras = report.Extras(comparison, _history_figures(doc, plan, run_time, stages))

    def finish() -> None:  # after the report: --history/--junit may point into the folder
        written, left = [f"the reports in {plan.target}"], []
        if history is not None:
            left.append(f"the history row in {history}")
        if junit is not None:
            left.append(f"the JUnit file {junit}")
        try:
            if history is not None:
                stages.step("history")
                append_history(history, doc, run_time, lock=False)  # held: write_run
                written.append(left.pop(0))
            if junit is not None:
                stages.step("JUnit")
                report.write_junit(junit, doc, comparison, time=time.perf_counter() - started,
                                   times=fit_times(records))
                written.append(left.pop(0))
        except UserError as exc:  # say exactly what this run did and did not write
            raise UserError(f"{exc.message}; written: {', '.join(written)}; not written: "
                            f"{', '.join(left)}") from None

    # nothing to draw: the sections are tables, built here; else the batch's pool draws
    stages.step("report sections", total=len(records))
    with parallel_map(pool if cfg.report.plots != "none" else None, len(records)) as mapper:
        report.write_run(plan.target, run, doc, title=cfg.report.title or
                         f"System identification: {cfg.name}", extras=extras,
                         markdown=cfg.report.markdown, html=cfg.report.html,
                         plots_mode=cfg.report.plots, mapper=stages.counting(mapper),
                         then=finish,
                         locks=() if history is None else (history_lock(
                             history, "nothing of this run was written (its reports, its "
                             "history row, its JUnit file)"),))
    return _outcome(run, comparison, plan.target, baseline)


@dataclass(frozen=True)
class _Plan:
    """What a run checks and reads before its batch (a bad one costs no run): the records
    (:func:`resolve_specs`), the report folder, the baseline document, and the history
    file with its rows so far (None: none yet)."""

    specs: list[RecordSpec]
    target: Path
    base_doc: ResultsDoc | None
    history: Path | None
    past: pl.DataFrame | None


def _not_outputs(specs: list[RecordSpec], outputs: dict[str, Path | None]
                 ) -> list[RecordSpec]:
    """The records without the run's own ``--history`` or ``--junit`` file, when a data
    folder or pattern matched it (issue 31: a history kept in the data folder was read as
    a log the next night), each skipped one said on stderr; when nothing else is left the
    records stay, and the output is refused as replacing its input."""
    kept = [s for s in specs if s.dataset or not any(
        p is not None and same_file(Path(s.path), Path(p)) for p in outputs.values())]
    if not kept or len(kept) == len(specs):
        return specs
    for s in specs:
        if s not in kept:
            what = next(w for w, p in outputs.items()
                        if p is not None and same_file(Path(s.path), Path(p)))
            log.warning("%s: the run's %s, not read as a log", s.path, what)
    return kept


def _plan(cfg: RunConfig, out_dir: Path | None, executor: str, baseline: Path | None,
          junit: Path | None, history: Path | None) -> _Plan:
    """The checks before the batch: the executor, the records, the output folder and
    files; the baseline (one of another config, records or methods is refused) and the
    history read."""
    check_executor(executor)
    specs = _not_outputs(resolve_specs(cfg), {"history": history, "JUnit file": junit})
    target = out_dir or cfg.report_folder()  # name is a label: never a path
    report.check_target(target)
    inputs = [(Path(cfg.source), "the config")] if cfg.source != "<config>" else []
    inputs += [(Path(s.path), f"the log of record {s.name!r}") for s in specs if not s.dataset]
    if baseline is not None:
        inputs.append((Path(baseline), "the baseline"))
    for path, what in ((junit, "JUnit file"), (history, "history")):
        if path is not None:
            check_writable(through_link(Path(path), what), what)  # where the write goes
            refuse_input(Path(path), what, inputs)
            owned = report.owned_file(Path(target), Path(path))
            if owned:
                raise UserError(f"{path}: is the report's own {owned} in {target}, which "
                                f"each run replaces; give the {what} another path")
            inputs.append((Path(path), f"the {what}"))
    if junit is not None:
        report.refuse_foreign_junit(Path(junit))
    base_doc = None if baseline is None else load_baseline(
        baseline, config=cfg.source, records=[s.name for s in specs], methods=cfg.methods)
    past = load_history(history) if history is not None and Path(history).exists() else None
    return _Plan(specs, Path(target), base_doc, history, past)


def _history_figures(doc: ResultsDoc, plan: _Plan, run_time: datetime, stages: Stages
                     ) -> list[tuple[str, bytes]]:
    """The history plots with this run's rows (the file is appended after the report),
    normalised to the baseline, else the first run; none without a history."""
    if plan.history is None:
        return []
    stages.step("history plots")
    rows = history_rows(doc, run_time)
    frame = rows if plan.past is None else pl.concat([plan.past, rows], how="diagonal_relaxed")
    return report.history_figures(frame, reference=None if plan.base_doc is None else
                                  report.baseline_reference(plan.base_doc))


def record_head_lines(res: RecordResult) -> list[str]:
    """The head of one record's answer in plain lines, as ``pipeline identify`` prints it:
    the recommended model with its verdict, its transfer function and scores, the
    verdict's reasons and the controller's first line (or why there is no model)."""
    box = report.recommended_box(res)
    if box is None:
        return [f"No model recommended for {res.name}: unreliable"] + [
            f"  {f.code}: {f.message}" for f in res.flags]
    lines = [f"Recommended model for {res.name}: {box['verdict']}",
             f"  G(s) = {box['tf']}   ({box['method']}, event {box['event']}; "
             f"{box['scores']})"]
    lines += [f"  {f['code']}: {f['message']}" for f in box["flags"]]
    if res.tuning is not None:
        lines += report.controller_lines(res.tuning)[:2]
    return lines


def _outcome(run: RunResult, comparison: Comparison | None, target: Path,
             baseline: Path | None) -> Outcome:
    """The exit code (all records failed, a regression, some failed, done) and the lines
    for the user: the counts by verdict, one line per regressed record."""
    records = run.records
    verdicts = [record_verdict(r) for r in records if r.ok]
    counts = ", ".join(f"{verdicts.count(v)} {v}" for v in ("ok", "warning", "unreliable"))
    messages = [f"{len(records) - len(run.failures)} of {len(records)} record(s) identified "
                f"({counts}); reports in {target}/"]
    if len(records) == 1 and records[0].ok:
        messages[:0] = record_head_lines(records[0])
    if comparison is not None:
        messages.extend(report.gate_lines(comparison, baseline))
    code = (ExitCode.USER_ERROR if len(run.failures) == len(records)
            else ExitCode.REGRESSION if comparison is not None and not comparison.ok
            else ExitCode.SOME_FAILED if run.failures else ExitCode.OK)
    return Outcome(code, target, run, messages)
