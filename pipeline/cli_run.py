"""``pipeline run`` once its options are parsed (the Typer command is in :mod:`pipeline.cli`):
options checked, logging set up (:mod:`pipeline.log`), the config run."""

from __future__ import annotations

from .errors import UserError


def run_command(config, out_dir, workers, executor, scheduler, baseline, junit, history,
                progress, param_tol, mse_tol, tol, quiet, verbose):
    """``pipeline run`` once its options are parsed: checked, logged, run."""
    from .baseline import Tolerances
    from .log import configure
    from .run import run_config

    if quiet and verbose:
        raise UserError("--quiet and --verbose: give one of them, not both")
    if scheduler is not None and executor != "dask":
        raise UserError(f"--scheduler {scheduler!r} needs --executor dask")
    configure("quiet" if quiet else "verbose" if verbose else "normal")
    tols = Tolerances(param_tol=param_tol, mse_tol=mse_tol, param_tols=tolerances(tol or []))
    return run_config(config, out_dir=out_dir, workers=workers, executor=executor,
                      scheduler=scheduler, baseline=baseline, junit=junit, history=history,
                      progress=False if quiet else progress, tolerances=tols)


def tolerances(items: list[str]) -> dict[str, float]:
    """``--tol K=0.1 --tol T=0.2`` as ``{"K": 0.1, "T": 0.2}``; names from the parameter
    table."""
    from .models import PARAMETERS

    out_ = {}
    for item in items:
        name, _, value = item.partition("=")
        name = name.strip()
        try:
            out_[name] = float(value)
        except ValueError:
            raise UserError(f"--tol {item!r}: expected PARAMETER=FRACTION, e.g. T=0.1") from None
        if name not in PARAMETERS:
            raise UserError(f"--tol {item!r}: unknown parameter {name!r}; expected one of "
                            + ", ".join(PARAMETERS))
    return out_
