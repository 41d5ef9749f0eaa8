"""Batch scaling: the same synthetic logs processed in-process and by a local process pool.

Writes ``--n`` synthetic logs (:func:`pipeline.synth.logs.write_synthetic_logs`, 4 steps
each, all methods) into a temporary folder, runs :func:`pipeline.batch.run_records` with
``workers=1`` and with ``--workers`` processes, checks that both give the same results, and
prints a Markdown snippet with the wall times (the first pool run includes starting the
workers and their imports, the second does not) and the speed-ups.

    python benchmarks/batch_scaling.py [--n 200] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

from pipeline.batch import run_records
from pipeline.config import config_from_dict
from pipeline.run import resolve_specs
from pipeline.synth.logs import write_synthetic_logs


def timed_run(specs, cfg, workers: int) -> tuple[float, list]:
    t0 = time.perf_counter()
    results = run_records(specs, cfg, workers=workers, progress=False)
    return time.perf_counter() - t0, results


def first_difference(a: list, b: list) -> str | None:
    """``None`` when both runs gave the same results, else the first record that differs."""
    for ra, rb in zip(a, b, strict=True):
        da, db = ra.to_dict(), rb.to_dict()
        if json.dumps(da, sort_keys=True) != json.dumps(db, sort_keys=True):
            fits = [(fa["method"], fa["params"], fb["params"]) for fa, fb in
                    zip(da["fits"], db["fits"], strict=False) if fa != fb]
            return f"{da['name']}: {fits[:1] or 'record fields differ'}"
    return None


def markdown(n: int, workers: int, times: dict[str, float], n_failed: int, n_fits: int,
             load: tuple[float, float]) -> str:
    t1 = times["inline"]
    rows = [f"| 1 (in-process) | {t1:.1f} | {n / t1:.1f} | 1.00 |"]
    for key, label in (("cold", "process pool, cold start"), ("warm", "process pool, warm")):
        t = times[key]
        rows.append(f"| {workers} ({label}) | {t:.1f} | {n / t:.1f} | {t1 / t:.2f} |")
    return "\n".join([
        f"### Batch scaling ({n} synthetic logs, all methods)",
        "",
        f"`python benchmarks/batch_scaling.py --n {n} --workers {workers}` on "
        f"{platform.python_implementation()} {platform.python_version()}, "
        f"{os.cpu_count()} CPU(s); 1-minute load average {load[0]:.1f} before and "
        f"{load[1]:.1f} after the runs; native BLAS/OpenMP pools limited to one thread in "
        "the in-process loop and in every pool worker (`pipeline.batch.limit_native_threads`).",
        "",
        "| workers | wall time (s) | records/s | speed-up |",
        "|---:|---:|---:|---:|",
        *rows,
        "",
        f"{n_fits} fits, {n_failed} failed record(s) (none expected); the pool's results are "
        "identical to the in-process ones. Cold start: the first pool of the process, which "
        "starts the fork server and imports `pipeline.run` (numpy, scipy, polars) once; "
        "warm: a second pool in the same process, forked from the already loaded server.",
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="number of logs")
    ap.add_argument("--workers", type=int, default=2, help="processes of the pool run")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "logs"
        write_synthetic_logs(folder, args.n, seed=args.seed)
        cfg = config_from_dict({"data": {"path": str(folder), "input": "u", "output": "y",
                                         "time": "time"}}, base_dir=str(folder))
        specs = resolve_specs(cfg)
        load_before = _load()
        times: dict[str, float] = {}
        times["inline"], inline = timed_run(specs, cfg, 1)
        times["cold"], pooled = timed_run(specs, cfg, args.workers)
        times["warm"], _ = timed_run(specs, cfg, args.workers)
        load_after = _load()
    diff = first_difference(inline, pooled)
    if diff:
        raise SystemExit(f"the pool gave different results from the in-process run: {diff}")
    n_failed = sum(1 for r in inline if not r.ok)
    n_fits = sum(len(r.fits) for r in inline)
    print(markdown(args.n, args.workers, times, n_failed, n_fits, (load_before, load_after)))


def _load() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


if __name__ == "__main__":
    main()
