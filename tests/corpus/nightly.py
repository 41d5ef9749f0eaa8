"""Corpus rows for hostile command-line options of the nightly path (issue 13 items 8, 17,
21): worker counts, executors, schedulers, verbosity."""

from tests.corpus import Hostile, config, step_csv

FILES = {"c.yaml": config("path: log.csv\ninput: u\noutput: y\ntime: time"),
         "log.csv": step_csv()}
KEEP = ("c.yaml", "log.csv")


def run(*options: str) -> tuple[str, ...]:
    return ("run", "c.yaml", "--out", "{d}/out", *options)


def no_report(d) -> None:
    assert not (d / "out").exists()


CASES = [
    Hostile("cli_workers_zero", run("--workers", "0"), 2, files=FILES, keep=KEEP,
            stderr=("workers must be at least 1",), check=no_report),
    Hostile("cli_workers_negative", run("--workers", "-3"), 2, files=FILES, keep=KEEP,
            stderr=("workers must be at least 1", "-3"), check=no_report),
    Hostile("cli_workers_not_a_number", run("--workers", "many"), 2, files=FILES, keep=KEEP,
            stderr=("--workers",), max_lines=6, check=no_report),  # click's usage box
    Hostile("cli_executor_bogus", run("--executor", "spark"), 2, files=FILES, keep=KEEP,
            stderr=("unknown executor 'spark'", "local, dask"), check=no_report),
    Hostile("cli_scheduler_unreachable",
            run("--executor", "dask", "--scheduler", "tcp://127.0.0.1:9"), 2, files=FILES,
            keep=KEEP, stderr=("cannot reach the Dask scheduler at tcp://127.0.0.1:9",),
            check=no_report),
    Hostile("cli_scheduler_malformed",
            run("--executor", "dask", "--scheduler", "tcp://127.0.0.1:notaport"), 2,
            files=FILES, keep=KEEP, stderr=("expected a Dask scheduler address",),
            check=no_report),
    Hostile("cli_scheduler_without_dask", run("--scheduler", "tcp://127.0.0.1:8786"), 2,
            files=FILES, keep=KEEP, stderr=("needs --executor dask",), check=no_report),
    Hostile("cli_quiet_and_verbose", run("--quiet", "--verbose"), 2, files=FILES, keep=KEEP,
            stderr=("--quiet and --verbose",), check=no_report),
    Hostile("cli_quiet_good_run_is_silent", run("--quiet", "--workers", "1"), 0, files=FILES,
            keep=KEEP, max_lines=0),
]
