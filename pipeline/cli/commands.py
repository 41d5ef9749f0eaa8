"""The ``pipeline`` command (Typer). Thin: parse, call the library, print.

One error handler (:func:`handled`) turns a :class:`~pipeline.errors.UserError` into one
line on stderr and :attr:`ExitCode.USER_ERROR`; the exit codes are
:class:`~pipeline.errors.ExitCode` (DESIGN.md).
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from ..errors import ExitCode, UserError
from ..quoting import printable
from ..version import __version__
from .data import with_data_options
from .help_types import example  # also --help's value words, not <bool>
from .output import (
    JsonOption,
    StdoutError,
    err,
    error_line,
    keep_whole,
    out,
    plain_error_line,
    print_json,
    print_ranking,
    report_stdout_failure,
    show,
    stdout_to_devnull,
)

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Batch system identification from step and impulse tests.")
datasets_app = typer.Typer(no_args_is_help=True, help="The public dataset registry.")
baseline_app = typer.Typer(no_args_is_help=True, help="Regression baselines.")
app.add_typer(datasets_app, name="datasets")
app.add_typer(baseline_app, name="baseline")


def handled(command):
    """The one error handler: a user error is one stderr line and exit code 2; a closed
    stdout (``| head -1``) ends the command quietly with :attr:`ExitCode.BROKEN_PIPE`
    (click's own handler would exit 1, the regression code); a full stdout (``--json >
    /dev/full``) is one line, exit code 2 (:class:`~.output.StdoutError`)."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except UserError as exc:
            error_line(exc.message)
            raise typer.Exit(ExitCode.USER_ERROR) from None
        except BrokenPipeError:
            stdout_to_devnull()
            raise typer.Exit(ExitCode.BROKEN_PIPE) from None
        except StdoutError as exc:
            report_stdout_failure(exc)
            raise typer.Exit(ExitCode.USER_ERROR) from None
        except (MemoryError, ImportError, OSError) as exc:
            if not out_of_memory(exc):
                raise
            plain_error_line(memory_message(exc))
            raise typer.Exit(ExitCode.USER_ERROR) from None

    return wrapper


def out_of_memory(exc: BaseException) -> bool:
    """Whether ``exc`` says the process ran out of memory: a MemoryError, an OSError
    ENOMEM, or a native module that could not be mapped (``failed to map segment``: an
    import under an address-space limit, issue 31)."""
    import errno

    if isinstance(exc, MemoryError):
        return True
    if isinstance(exc, OSError) and exc.errno == errno.ENOMEM:
        return True
    text = str(exc).lower()
    return isinstance(exc, ImportError | OSError) and (
        "failed to map segment" in text or "cannot allocate memory" in text)


def memory_message(exc: BaseException) -> str:
    """One line for :func:`out_of_memory`: what failed and how much memory was left."""
    from ..memory import available

    free = available()
    left = f"; {free / 2**20:.0f} MB is left to this process" if free is not None else ""
    what = " ".join(f"{type(exc).__name__}: {exc}".split())[:160]
    return (f"out of memory ({what}){left}; give the command more memory (its ulimit or "
            "container limit), or split the log")



def _version(value: bool) -> None:
    if value:
        out.print(f"pipeline {__version__}", markup=False)
        raise typer.Exit(ExitCode.OK)


@app.callback()
def main(version: Annotated[bool, typer.Option(
        "--version", callback=_version, is_eager=True, help="print the version and exit")]
        = False) -> None:
    """Batch system identification from step and impulse tests."""
    from ..log import configure

    configure()  # every command: library warnings only with run --verbose


def stoppable(command):
    """SIGTERM and SIGINT stop the command cleanly (:mod:`pipeline.batch.interrupt`): its
    ``finally`` blocks run (workers ended, temporary folders removed), one line says so,
    and the exit code is 128 + the signal (143, 130)."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from ..batch import handle_signals, interruption

        with handle_signals():
            try:
                return command(*args, **kwargs)
            except BaseException as caught:
                if (exc := interruption(caught)) is None:  # it may come wrapped (an import)
                    raise
                err.print(f"interrupted by {exc.name}: stopped, workers ended; nothing "
                          "half-written (the previous report kept, or the new one complete "
                          "when the signal came while it was put in place)", markup=False)
                raise typer.Exit(exc.exit_code) from None

    return wrapper


# -- run ---------------------------------------------------------------------------------

@app.command(epilog=example("run"))
@stoppable
@handled
def run(
    config: Annotated[Path, typer.Argument(help="YAML run configuration")],
    out_dir: Annotated[Path | None, typer.Option("--out", help="output folder")] = None,
    workers: Annotated[int | None, typer.Option(help="parallel processes (default: cores)")] = None,
    executor: Annotated[str, typer.Option(help="local or dask")] = "local",
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address")] = None,
    baseline: Annotated[Path | None, typer.Option(help="earlier results.json to compare")] = None,
    junit: Annotated[Path | None, typer.Option(help="write JUnit XML here")] = None,
    history: Annotated[Path | None, typer.Option(help="parquet history to append to")] = None,
    allow_failures: Annotated[bool, typer.Option(help="exit 0 although some records failed")]
    = False,
    progress: Annotated[bool | None, typer.Option(help="progress bar (default: on a terminal)")]
    = None,
    param_tol: Annotated[float, typer.Option(help="gain drift tolerance (dynamics: 3x)")]
    = 0.05,
    mse_tol: Annotated[float, typer.Option(help="validation MSE growth tolerance")] = 0.10,
    tol: Annotated[list[str] | None, typer.Option(
        help="per-parameter tolerance, e.g. --tol T=0.1 or --tol Kc=0.2 (repeatable)")]
    = None,
    check: Annotated[bool, typer.Option(
        "--check", help="check the config, its files and their columns; identify nothing")]
    = False,
    gate: Annotated[str, typer.Option(
        metavar="recommended|all",
        help="what fails the gate: the recommended model (its parameters, tuning, verdict, "
             "validation error) or every method; the others are listed for information")]
    = "recommended",
    quiet: Annotated[bool, typer.Option(
        "--quiet", "-q", help="errors only on stderr (no progress bar)")] = False,
    verbose: Annotated[bool, typer.Option(
        "--verbose", "-v", help="each record's time (its stages when it runs in this "
                                "process), each report step, library warnings, on stderr")]
    = False,
) -> None:
    """Identify and validate every record a config names; write results.json and reports.

    SIGTERM or Ctrl-C stops the run cleanly: the workers end, nothing half-written is
    left, an earlier report in --out is kept; the exit code is 143 (SIGTERM) or 130.
    """
    if check:
        from .check import check_config

        code, rows = check_config(config)
        for r in rows:
            (error_line if r.error else out.print)(r.line(), **({} if r.error else
                                                            {"markup": False}))
        raise typer.Exit(code)
    from .run_command import run_command

    outcome = run_command(config, out_dir, workers, executor, scheduler, baseline, junit,
                          history, progress, param_tol, mse_tol, tol, quiet, verbose, gate)
    for line in outcome.run.failures:
        error_line(line)
    for line in outcome.messages:
        out.print(printable(line), markup=False)
    code = outcome.exit_code
    if code == ExitCode.SOME_FAILED and allow_failures:
        code = ExitCode.OK
    raise typer.Exit(code)


# -- identify / segment ------------------------------------------------------------------

def _list_arg(values: list[str] | None) -> list[str]:
    """``--x a,b`` and ``--x a --x b`` alike."""
    return [v.strip() for item in values or [] for v in item.split(",") if v.strip()]


def _events_arg(text: str) -> tuple[int, ...] | str:
    if text.strip() == "all":
        return "all"
    try:
        events = tuple(int(x) for x in _list_arg([text]))
    except ValueError:
        events = ()
    if not events or min(events) < 0:
        raise UserError(f"--events {text!r}: expected 'all' or indices >= 0 like 0,2")
    return events


def _methods_arg(values: list[str] | None) -> tuple[str, ...] | str:
    from ..methods import REGISTRY

    ids = _list_arg(values)
    unknown = [m for m in ids if m != "all" and m not in REGISTRY]
    if unknown:
        from ..suggest import did_you_mean

        raise UserError(f"--method {unknown[0]!r}: unknown{did_you_mean(unknown[0], REGISTRY)}"
                        "; see `pipeline methods`")
    return "all" if not ids or "all" in ids else tuple(ids)


FileArg = Annotated[Path, typer.Argument(
    help="a log: .csv/.tsv/.txt, .dat, .mat, .xlsx, .parquet/.feather/.arrow or .mcap")]


@app.command(context_settings={"allow_extra_args": True}, epilog=example("identify"))
@stoppable
@handled
@with_data_options
def identify(
    ctx: typer.Context,
    file: FileArg,
    data,
    method: Annotated[list[str] | None, typer.Option(
        "--method", help="method ids, 'all' (default): --method a,b or --method a --method b")]
    = None,
    events: Annotated[str, typer.Option(help="identification events: 'all' or 0,2")] = "0",
    consistency: Annotated[bool | None, typer.Option(
        "--consistency/--no-consistency",
        help="identify every step on its own and compare (default: with 3 steps or more)")]
    = None,
    as_json: Annotated[bool, typer.Option("--json", help="print results JSON to stdout")]
    = False,
    out_dir: Annotated[Path | None, typer.Option("--out", help="also write reports here")]
    = None,
    workers: Annotated[int | None, typer.Option(
        help="parallel processes for a long log's fits (default: cores)")] = None,
    quiet: Annotated[bool, typer.Option(
        "--quiet", "-q", help="print the recommended model's head lines only")] = False,
    verbose: Annotated[bool, typer.Option(
        "--verbose", "-v", help="the stages and library warnings on stderr")] = False,
) -> None:
    """Identify models from one log and print them ranked (or as JSON)."""
    from ..analysis import AnalysisOptions
    from ..log import configure
    from ..run import identify_file, identify_json, record_head_lines

    if quiet and verbose:
        raise UserError("--quiet and --verbose: give one of them, not both")
    configure("quiet" if quiet else "verbose" if verbose else "normal")

    if ctx.args:
        raise UserError(f"unexpected argument {ctx.args[0]!r}: give several methods or events "
                        "with commas (--method first_order,smith, --events 0,2) or repeat "
                        "the option (--method first_order --method smith)")
    options = AnalysisOptions(events=_events_arg(events), methods=_methods_arg(method),
                              consistency=consistency)
    if as_json:
        sys.stdout.write(identify_json(file, data, options, out_dir=out_dir, workers=workers))
        return
    run_ = identify_file(file, data, options, out_dir=out_dir, workers=workers)
    if quiet:
        for line in record_head_lines(run_.records[0]):
            out.print(printable(line), markup=False)
        return
    print_ranking(run_.records[0])
    if out_dir is not None:
        out.print(f"reports written to {out_dir}/ (report.html, report.md, results.json)")



@app.command(context_settings={"allow_extra_args": True}, epilog=example("tune"))
@handled
def tune(
    ctx: typer.Context,
    source: Annotated[str, typer.Argument(
        help="a results.json, or a model structure followed by its parameters: "
             "first_order K=2 T=10 delay=1")],
    rule: Annotated[str, typer.Option(help="simc, simc_improved, lambda or amigo")] = "simc",
    kind: Annotated[str, typer.Option(help="auto, P, PI or PID")] = "auto",
    tau_c: Annotated[str | None, typer.Option(
        "--tau-c", help="closed-loop time constant (lambda) in s, or tight, smooth, robust "
                        "(the fastest with worst-case Ms at most --ms-target)")] = None,
    ms_target: Annotated[float, typer.Option(help="worst-case Ms for --tau-c robust")] = 1.7,
    form: Annotated[str, typer.Option(help="ideal, parallel or series")] = "ideal",
    time_unit: Annotated[str, typer.Option(help="s or min")] = "s",
    input_span: Annotated[float | None, typer.Option(help="input instrument span")] = None,
    output_span: Annotated[float | None, typer.Option(help="output instrument span")] = None,
    record: Annotated[str | None, typer.Option(help="only this record of a results.json")]
    = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the tuning as JSON")] = False,
) -> None:
    """Tune a controller from identified models: `pipeline tune reports/x/results.json`
    or `pipeline tune first_order K=2 T=10 delay=1 --rule amigo`."""
    import json

    from ..config import TuningConfig
    from ..report import controller_lines
    from ..tuning import tuning_doc
    from .tune_command import tune_command

    raw = {"rule": rule, "kind": kind, "form": form, "time_unit": time_unit,
           "input_span": input_span, "output_span": output_span, "ms_target": ms_target}
    if tau_c is not None:
        try:
            raw["tau_c"] = float(tau_c)
        except ValueError:
            raw["tau_c"] = tau_c
    from pydantic import ValidationError

    try:
        options = TuningConfig.model_validate(raw).options()
    except ValidationError as exc:
        e = exc.errors()[0]
        key = str(e["loc"][0]).replace("_", "-")
        raise UserError(f"--{key} {raw.get(e['loc'][0])!r}: "
                        f"{e['msg'].removeprefix('Value error, ')}") from None
    results = tune_command(source, list(ctx.args), options, record)
    if as_json:
        docs = [{"name": n, "tuning": tuning_doc(rt).model_dump(mode="json")}
                for n, rt in results]
        sys.stdout.write(json.dumps(docs, indent=1) + "\n")
        return
    for name, rt in results:
        out.print(f"{printable(name)}:", markup=False)
        for line in controller_lines(rt):
            out.print(printable(line), markup=False)


@app.command(epilog=example("segment"))
@handled
@with_data_options
def segment(
    file: FileArg,
    data,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON")] = False,
) -> None:
    """Print the step and impulse events found in a log."""
    import json

    from ..io import load_record
    from ..report import fmt, response_text
    from ..results import event_doc
    from ..segmentation import segment as find_events

    record = load_record(file, data)
    events = find_events(record)
    if as_json:
        docs = [event_doc(e, "unused").model_dump(mode="json", exclude={"role"})
                for e in events]
        sys.stdout.write(json.dumps(docs, indent=1) + "\n")
        return
    tab = Table(title=escape(printable(f"{record.name}: {len(events)} event(s)")))
    for col in ("#", "kind", "t0", "t_end", "u0", "u_ss / area", "y0", "y_ss", "response",
                "settled"):
        tab.add_column(col)
    for e in events:
        tab.add_row(str(e.index), e.kind, fmt(e.t0), fmt(e.t_end), fmt(e.u0),
                    fmt(e.u_ss) if e.kind == "step" else f"A={fmt(e.area)}", fmt(e.y0),
                    fmt(e.y_ss), response_text(e, record),
                    "yes" if e.settled else "no (still moving)")
    show(tab)


@app.command(epilog=example("methods"))
@handled
def methods(as_json: JsonOption = False) -> None:
    """List the identification methods: id, event kind, model structures, reference."""
    from .catalogue import catalogue  # metadata only: no scipy to start

    rows = catalogue()
    if as_json:
        print_json(rows)
        return
    tab = Table(title="Methods")
    for col in ("id", "event", "structures", "title", "reference"):
        tab.add_column(col)
    for m in rows:
        tab.add_row(m["id"], m["event"], ", ".join(m["structures"]), m["title"],
                    m["citation"])
    keep_whole(tab, 0, [m["id"] for m in rows])
    keep_whole(tab, 2, [" ".join(m["structures"]) for m in rows])
    show(tab)


@app.command(epilog=example("schema"))
@handled
def schema(config: Annotated[bool, typer.Option(
        "--config", help="the run config's schema instead (for an editor's YAML support)")]
        = False) -> None:
    """Print the JSON Schema of results.json (or, with --config, of a run config)."""
    if config:
        from .check import config_schema_text

        sys.stdout.write(config_schema_text())
        return
    from ..schema import json_schema_text

    sys.stdout.write(json_schema_text())


@app.command(epilog=example("inspect"))
@handled
def inspect(file: Annotated[Path, typer.Argument(help="an .mcap log")],
            as_json: JsonOption = False) -> None:
    """Topics, schemas, encodings, counts, time span and numeric fields of an MCAP log."""
    from ..io import format_inspect, inspect_mcap

    info = inspect_mcap(file)
    if as_json:
        print_json(info)
        return
    tab = format_inspect(info)
    for k, key in ((0, "topic"), (1, "schema")):
        keep_whole(tab, k, [t[key] or "-" for t in info["topics"]])
    keep_whole(tab, 5, [f for t in info["topics"] for f in t["fields"][:12]])
    show(tab)


# -- datasets ----------------------------------------------------------------------------

@datasets_app.command("list", epilog=example("datasets list"))
@handled
def datasets_list(as_json: JsonOption = False) -> None:
    """The registered public datasets."""
    from ..io import load_registry

    reg = load_registry()
    if as_json:
        print_json([{"name": ds.name, "title": ds.title, "format": ds.format,
                     "input": ds.input, "output": ds.output, "url": ds.url}
                    for ds in reg.values()])
        return
    tab = Table(title="Datasets")
    for col in ("name", "title", "format", "signals", "source"):
        tab.add_column(col)
    for ds in reg.values():
        tab.add_row(ds.name, ds.title, ds.format, f"{ds.input} -> {ds.output}", ds.url)
    keep_whole(tab, 0, [ds.name for ds in reg.values()])
    keep_whole(tab, 4, [ds.url for ds in reg.values()])  # a URL must be copied whole
    show(tab)


@datasets_app.command("fetch", epilog=example("datasets fetch"))
@handled
def datasets_fetch(name: Annotated[str, typer.Argument(help="dataset name")]) -> None:
    """Fetch a dataset into the local cache (sha256 checked)."""
    from ..io import fetch

    out.print(str(fetch(name)), markup=False)


@datasets_app.command("synth", epilog=example("datasets synth"))
@handled
def datasets_synth(
    folder: Annotated[Path, typer.Argument(help="where to write the logs")],
    n: Annotated[int, typer.Option("--n", help="number of logs")] = 20,
    seed: Annotated[int, typer.Option(help="random seed")] = 0,
    gain_drift: Annotated[float, typer.Option(help="relative gain change, e.g. 0.1")] = 0.0,
    noise_seed: Annotated[int | None, typer.Option(help="fresh noise, same plants")] = None,
    corrupt: Annotated[int, typer.Option(help="how many of the logs to corrupt")] = 0,
) -> None:
    """Write synthetic step-test logs with known plants (for examples and CI)."""
    from ..synth import write_synthetic_logs

    paths = write_synthetic_logs(folder, n, seed=seed, gain_drift=gain_drift, corrupt=corrupt,
                                 noise_seed=noise_seed)
    out.print(f"wrote {len(paths)} logs to {folder}", markup=False)


# -- baseline ----------------------------------------------------------------------------

@baseline_app.command("accept", epilog=example("baseline accept"))
@handled
def baseline_accept(
    results: Annotated[Path, typer.Argument(help="a run's results.json")],
    to: Annotated[Path, typer.Option("--to", help="baseline file")] = Path(
        "reports/baselines/baseline.json"),
) -> None:
    """Promote a run's results.json to be the baseline."""
    from ..gate import accept

    accept(results, to)
    out.print(f"baseline {to} <- {results}", markup=False)
