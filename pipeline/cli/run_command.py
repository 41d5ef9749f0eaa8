"""``pipeline run`` once its options are parsed (the Typer command is in :mod:`pipeline.cli`):
options checked, logging set up (:mod:`pipeline.log`), the config run."""

from __future__ import annotations

from ..errors import UserError


def run_command(config, out_dir, workers, executor, scheduler, baseline, junit, history,
                progress, param_tol, mse_tol, tol, quiet, verbose, gate="recommended"):
    """``pipeline run`` once its options are parsed: checked, logged, run."""
    from ..log import configure
    from ..run import run_config

    if quiet and verbose:
        raise UserError("--quiet and --verbose: give one of them, not both")
    if scheduler is not None and executor != "dask":
        raise UserError(f"--scheduler {scheduler!r} needs --executor dask")
    configure("quiet" if quiet else "verbose" if verbose else "normal")
    if gate not in ("recommended", "all"):
        raise UserError(f"--gate {gate!r}: expected recommended or all")
    tols = tolerances(tol or [], param_tol=param_tol, mse_tol=mse_tol, scope=gate)
    return run_config(config, out_dir=out_dir, workers=workers, executor=executor,
                      scheduler=scheduler, baseline=baseline, junit=junit, history=history,
                      progress=False if quiet else progress, tolerances=tols)


def tolerances(items: list[str], *, param_tol: float = 0.05, mse_tol: float = 0.10,
               scope: str = "recommended"):
    """The gate's :class:`~pipeline.gate.Tolerances` from ``--param-tol``, ``--mse-tol``
    and each ``--tol PARAMETER=FRACTION`` (names from the parameter table); a NaN,
    negative or infinite one (the gate would switch off or fire on everything) is one
    line naming the option."""
    from ..gate import SETTINGS, Tolerances, tolerance_problem
    from ..models import PARAMETERS

    for option, name, value in (("--param-tol", "param_tol", param_tol),
                                ("--mse-tol", "mse_tol", mse_tol)):
        problem = tolerance_problem(name, value)
        if problem:
            raise UserError(f"{option} {value!r}: {problem}")
    per = {}
    for item in items:
        name, eq, value = item.partition("=")
        name = name.strip()
        try:
            per[name] = float(value) if eq else float("x")
        except ValueError:
            raise UserError(f"--tol {item!r}: expected PARAMETER=FRACTION, e.g. T=0.1") from None
        if name not in PARAMETERS and name not in SETTINGS:
            raise UserError(f"--tol {item!r}: unknown parameter {name!r}; expected one of "
                            + ", ".join((*PARAMETERS, *SETTINGS)))
        problem = tolerance_problem(f"tolerance of {name}", per[name])
        if problem:
            raise UserError(f"--tol {item!r}: {problem}")
    return Tolerances(param_tol=param_tol, mse_tol=mse_tol, param_tols=per, scope=scope)
