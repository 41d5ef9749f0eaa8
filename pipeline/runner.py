"""``pipeline run``: one config from YAML to reports, with the batch, baseline and history
options. Returns an :class:`Outcome` (exit code and messages); the CLI only prints it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

from .config import load_config
from .report.build import Extras, write_run
from .run import RecordResult, resolve_specs, results_document


@dataclass(frozen=True)
class Outcome:
    exit_code: int
    out_dir: Path | None
    results: list[RecordResult] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)


def execute(config: Path, *, out_dir: Path | None = None, workers: int | None = None,
            executor: str = "local", scheduler: str | None = None,
            baseline: Path | None = None, junit: Path | None = None,
            history: Path | None = None, progress: bool | None = None,
            created: str = "", param_tol: float = 0.05, mse_tol: float = 0.10,
            param_tols: dict[str, float] | None = None) -> Outcome:
    """Run a config end to end (see the CLI's ``run``); user errors raise UserError."""
    cfg = load_config(config)
    specs = resolve_specs(cfg)
    results = process_all(specs, cfg, workers=workers, executor=executor,
                          scheduler=scheduler, progress=progress)
    failures = [r.error for r in results if not r.ok]
    if len(failures) == len(results):
        return Outcome(2, None, results, failures)
    doc = results_document(results, str(config), created)
    extras = Extras()
    messages: list[str] = []
    regressions = 0
    comparison = None
    if baseline is not None:
        from .baseline import compare, load_results

        comparison = compare(doc, load_results(baseline), param_tol=param_tol,
                             mse_tol=mse_tol, param_tols=param_tols)
        extras.regressions = [f.as_row() for f in comparison.regressions]
        extras.new = [str(f) for f in comparison.new]
        regressions = len(comparison.regressions)
        messages.append(f"{regressions} regression(s) against {baseline}")
    run_time = datetime.fromisoformat(created) if created else None
    if history is not None:
        import polars as pl

        from .history import history_rows, load_history
        from .report.history_plots import history_figures

        rows = history_rows(doc, run_time)  # the file is appended after the report
        past = load_history(history) if Path(history).exists() else None
        frame = rows if past is None else pl.concat([past, rows], how="diagonal_relaxed")
        extras.history = history_figures(frame)
    target = out_dir or Path(cfg.output or Path("reports") / cfg.name)
    from .batch import parallel_map

    with parallel_map(workers if executor == "local" else 1, len(results)) as mapper:
        write_run(target, results, doc, title=cfg.report.title or f"System identification: "
                  f"{cfg.name}", extras=extras, markdown=cfg.report.markdown,
                  html=cfg.report.html, plots_mode=cfg.report.plots, mapper=mapper)
    if history is not None:  # after the report too, for the same reason
        from .history import append_history

        append_history(history, doc, run_time)
    if junit is not None:  # after the report: --junit may point into the output folder
        from .report.junit import write_junit

        write_junit(junit, doc, comparison)
    ok = len(results) - len(failures)
    messages.insert(0, f"{ok} of {len(results)} record(s) identified; reports in {target}/")
    code = 1 if regressions else (3 if failures else 0)
    return Outcome(code, target, results, failures, messages)


def process_all(specs, cfg, *, workers=None, executor="local", scheduler=None, progress=None
                ) -> list[RecordResult]:
    from .batch import run_records

    return run_records(specs, cfg, workers=workers, executor=executor, scheduler=scheduler,
                       progress=progress)
