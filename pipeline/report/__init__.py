"""Reports: results.json, Markdown and HTML with plots, JUnit XML, history plots.

Its names are imported on first use (matplotlib and Jinja2 load only when a report is
made: ``pipeline identify`` without ``--out`` never pays for them).
"""

from importlib import import_module

#: public name -> module of this package that defines it
_EXPORTS = {
    "Extras": "build", "write_run": "build",
    "baseline_reference": "history_plots", "history_figures": "history_plots",
    "write_junit": "junit", "refuse_foreign_junit": "junit", "check_target": "outdir",
    "owned_file": "outdir",
    "gate_lines": "regressions",
    "fmt": "tables", "PARAMETERS_COLUMN": "tables",
    "ranking_table": "tables", "recommended_box": "tables",
    "response_text": "tables", "controller_lines": "controller",
    "running_loop_lines": "running_loop",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
