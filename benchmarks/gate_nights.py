"""The nightly gate on 20 plants a night (issue 29): fresh noise alone must pass it, a
10 % gain drift must fail it.

    python benchmarks/gate_nights.py [--plants 20] [--pairs 20] [--workers 2]

Nights are :func:`pipeline.synth.logs.plan_logs` (first order with dead time, four steps
from a moving operating point, white noise of 1 % of the step; the same plants every
night, ``noise_seed`` the night), analysed as ``pipeline run`` does (every method). For
each of ``--pairs`` consecutive pairs of nights, :func:`pipeline.gate.baseline.compare`
(the default gate: the recommended model) of the second against the first; then the
same plants with their gains 10 % higher against each first night. Prints the machine,
the pairs that pass (claim: at least 19 of 20), the drifted nights in which every
record's gain is a finding (claim: 20 of 20), the other methods' findings (information:
what made the gate red before it was scoped), and the findings that failed a fresh-noise
pair. ``--keep FILE`` writes every night's results (one JSON document a line: the fresh
nights, then the drifted ones) to try the gate's rules on without analysing again.
``tests/test_gate_scope.py`` is the same check on 3 plants a night.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from concurrent.futures import ProcessPoolExecutor

import pipeline
from pipeline.analysis import AnalysisOptions
from pipeline.gate.baseline import compare
from pipeline.results import RunResult
from pipeline.synth.logs import log_record, plan_logs


def night(args: tuple[int, int, float]):
    plants, noise_seed, drift = args
    plans = plan_logs(plants, seed=7, noise_seed=noise_seed, gain_drift=drift)
    return RunResult([pipeline.analyse(log_record(p), AnalysisOptions())
                      for p in plans]).to_doc()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--plants", type=int, default=20)
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--keep", default=None, help="write the nights' results (JSON lines)")
    a = ap.parse_args()
    print(f"{a.plants} plants a night, {a.pairs} pairs; {a.workers} workers; "
          f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    t0 = time.perf_counter()
    jobs = [(a.plants, k, 0.0) for k in range(a.pairs + 1)]
    jobs += [(a.plants, 100 + k, 0.10) for k in range(a.pairs)]
    with ProcessPoolExecutor(a.workers) as ex:
        docs = list(ex.map(night, jobs))
    fresh, drifted = docs[:a.pairs + 1], docs[a.pairs + 1:]
    if a.keep:
        with open(a.keep, "w", encoding="utf-8") as out:
            for doc in docs:
                out.write(doc.model_dump_json() + "\n")
    passed, other, failures = 0, 0, []
    for k, (base, cur) in enumerate(zip(fresh, fresh[1:], strict=False)):
        c = compare(cur, base)
        passed += c.ok
        other += len(c.other)
        failures += [f"pair {k}: {f.message}" for f in c.regressions]
    caught = 0
    for base, cur in zip(fresh, drifted, strict=False):
        c = compare(cur, base)
        gains = {f.record for f in c.regressions if f.parameter == "K"}
        caught += gains == {r.name for r in base.records}
    print(f"wall time {time.perf_counter() - t0:.0f} s\n")
    print("| check | result | claim |")
    print("|---|---:|---|")
    print(f"| fresh noise: pairs that pass | {passed} of {a.pairs} | at least "
          f"{a.pairs - a.pairs // 20} |")
    print(f"| 10 % gain drift: nights with every gain a finding | {caught} of {a.pairs} | "
          f"all |")
    print(f"| other methods' findings on fresh noise (information) | {other} | - |")
    if failures:
        print("\nfindings that failed a fresh-noise pair:")
        for line in failures[:20]:
            print(f"- {line}")


if __name__ == "__main__":
    main()
