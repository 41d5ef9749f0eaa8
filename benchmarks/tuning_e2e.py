"""Tuning end to end from a noisy step test, checked on the true plant (issue 28).

    python benchmarks/tuning_e2e.py [--seeds 50] [--workers 2] [--plants "P4 L=1 T=1,P6"]
                                    [--kinds white,ar1] [--json rows.json]

Every plant of Åström & Hägglund's PID benchmark families (K. J. Åström and T.
Hägglund, "Benchmark systems for PID control", IFAC PID'00, Terrassa, 2000; the test
batch of their *Advanced PID Control*, ISA 2006, Section 7.2): P1 equal poles, P2 spread
lags, P3 a right-half-plane zero, P4 dead time and lag, P5 dead time and double lag, P6
fast and slow modes, P7 oscillatory (the members and their sampling periods:
:data:`tests.tuning_plants.PLANTS`). Per plant, noise kind (1 % of the output change,
white or AR(1) with phi 0.8) and seed: a step test logged from a nonzero operating point
(up at a seed-dependent time, down once settled, :func:`tests.tuning_plants.step_test`),
``pipeline.identify`` on it, the SIMC tuning of the recommended model (Skogestad, "Simple
analytic rules for model reduction and PID controller tuning", *J. Process Control* 13
(2003) 291-309), and those settings on the TRUE plant: Nyquist stability and Ms with the
exact dead time (:func:`pipeline.tuning.loop_margins`; Åström & Murray, *Feedback
Systems*, 2008, Theorem 9.2; Ms as in Skogestad & Postlethwaite 2005, Section 2.4.3).

The claims (Åström & Hägglund 2006, Section 4.3: Ms above 2 is poorly damped): the loop
is stable in 100 % of seeds, the true Ms is at most 2.0 in at least 95 % of seeds, and no
tuning is called "robust" when its true Ms exceeds 2. Prints the machine, the time of one
bare ``pipeline.identify`` on the P4 plant (the unit of the per-run time ratio), a
Markdown table per plant and noise kind (seeds, stable %, true Ms median / 95th
percentile / max, % with Ms <= 2, "robust" with Ms > 2, the verdicts, wall time) and the
seeds that break a claim, with the model they came from. ``--json`` keeps every row.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.tuning_plants import (  # noqa: E402
    BASELINE_PLANT,
    MS_LIMIT,
    MS_SHARE,
    NOISE_KINDS,
    PLANTS,
    run_case,
    step_test,
)

VERDICTS = ("robust", "fragile", "unstable_in_interval", "unchecked", None)
SHORT = {"robust": "rob", "fragile": "frag", "unstable_in_interval": "unst",
         "unchecked": "unch", None: "none"}


def one(job: tuple[str, str, int]) -> dict:
    t0 = time.perf_counter()
    row = run_case(*job)
    row["wall"] = time.perf_counter() - t0
    return row


def baseline_seconds(repeats: int = 3) -> float:
    """The median time of one bare ``pipeline.identify`` (it tunes too: the default) on
    the P4 plant's white-noise step test, seed 0, after one warm-up call."""
    import pipeline

    t, u, y = step_test(PLANTS[BASELINE_PLANT], "white", 0)
    pipeline.identify(t, u, y)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        pipeline.identify(t, u, y)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _ms(v: float) -> str:
    return "inf" if not math.isfinite(v) else f"{v:.2f}"


def summary(rows: list[dict]) -> dict:
    ms = np.array([r.get("true_ms", math.inf) for r in rows], dtype=float)
    n = len(rows)
    verdicts = collections.Counter(r.get("verdict") for r in rows)
    return {"n": n,
            "stable": sum(1 for r in rows if r.get("true_stable")) / n,
            "ms_median": float(np.median(ms)), "ms_p95": float(np.percentile(ms, 95)),
            "ms_max": float(np.max(ms)),
            "ms_ok": float(np.mean(ms <= MS_LIMIT)),
            "robust_above": sum(1 for r in rows if r.get("verdict") == "robust"
                                and r.get("true_ms", math.inf) > MS_LIMIT),
            "verdicts": {str(k): verdicts.get(k, 0) for k in VERDICTS if verdicts.get(k)},
            "wall": float(sum(r["wall"] for r in rows)),
            "per_run": float(np.mean([r["wall"] for r in rows]))}


def report(rows: list[dict], base: float) -> tuple[list[dict], bool]:
    print("| plant | noise | seeds | stable % | true Ms median / p95 / max | Ms <= 2 % | "
          "robust & Ms > 2 | verdicts (rob/frag/unst/unch) | wall s | per run / baseline |")
    print("|---|---|---:|---:|---|---:|---:|---|---:|---:|")
    out, ok = [], True
    for name in PLANTS:
        for kind in NOISE_KINDS:
            part = [r for r in rows if r["plant"] == name and r["kind"] == kind]
            if not part:
                continue
            s = summary(part)
            v = s["verdicts"]
            passed = (s["stable"] == 1.0 and s["ms_ok"] >= MS_SHARE
                      and s["robust_above"] == 0 and "None" not in v)
            ok &= passed
            print(f"| {name} | {kind} | {s['n']} | {100 * s['stable']:.0f} | "
                  f"{_ms(s['ms_median'])} / {_ms(s['ms_p95'])} / {_ms(s['ms_max'])} | "
                  f"{100 * s['ms_ok']:.0f}{'' if s['ms_ok'] >= MS_SHARE else ' **'} | "
                  f"{s['robust_above']}{'' if s['robust_above'] == 0 else ' **'} | "
                  f"{v.get('robust', 0)}/{v.get('fragile', 0)}/"
                  f"{v.get('unstable_in_interval', 0)}/{v.get('unchecked', 0)}"
                  f"{' (' + str(v['None']) + ' untuned)' if 'None' in v else ''} | "
                  f"{s['wall']:.1f} | {s['per_run'] / base:.2f} |")
            out.append({"plant": name, "kind": kind, "passed": passed, **s})
    return out, ok


def failures(rows: list[dict], per_case: int = 4) -> None:
    bad = [r for r in rows if not r.get("true_stable") or r.get("true_ms", math.inf) > MS_LIMIT
           or r.get("verdict") is None]
    if not bad:
        print("\nno seed breaks a claim")
        return
    print(f"\nseeds with an unstable loop, a true Ms above {MS_LIMIT:g} or no tuning "
          f"({len(bad)}; at most {per_case} per case):\n")
    print("| plant | noise | seed | recommended | model (verdict) | controller | Ms model / "
          "worst / TRUE | stable | verdict |")
    print("|---|---|---:|---|---|---|---|---|---|")
    seen: collections.Counter = collections.Counter()
    for r in bad:
        key = (r["plant"], r["kind"])
        seen[key] += 1
        if seen[key] > per_case:
            continue
        p = ", ".join(f"{k}={v:.3g}" for k, v in (r.get("params") or {}).items())
        c = r.get("controller") or {}
        ctl = (f"{c.get('kind')} Kc={c.get('Kc', math.nan):.3g} Ti={c.get('Ti', math.nan):.3g}"
               f" Td={c.get('Td', 0.0):.3g}") if c else r.get("reason", "")
        worst = r.get("worst_ms")
        print(f"| {r['plant']} | {r['kind']} | {r['seed']} | {r.get('method')} | "
              f"{r.get('structure')} {p} ({r.get('model_verdict')}) | {ctl} | "
              f"{_ms(r.get('model_ms', math.nan))} / "
              f"{'-' if worst is None else _ms(worst)} / {_ms(r.get('true_ms', math.inf))} | "
              f"{r.get('true_stable')} | {r.get('verdict')} |")
    for key, n in seen.items():
        if n > per_case:
            print(f"| {key[0]} | {key[1]} | ... {n - per_case} more | | | | | | |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--plants", default=",".join(PLANTS))
    ap.add_argument("--kinds", default=",".join(NOISE_KINDS))
    ap.add_argument("--json", default=None, help="write every row and the summary here")
    a = ap.parse_args()
    plants = [p.strip() for p in a.plants.split(",") if p.strip()]
    unknown = [p for p in plants if p not in PLANTS]
    if unknown:
        ap.error(f"unknown plant(s) {unknown}; one of {list(PLANTS)}")
    jobs = [(p, k, s) for p in plants for k in a.kinds.split(",") for s in range(a.seeds)]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=ROOT).stdout.strip()
    print(f"{len(jobs)} step tests ({len(plants)} plants x {a.kinds} x {a.seeds} seeds) at "
          f"{commit or '?'} (work tree); {a.workers} workers; {platform.platform()}, "
          f"{platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}")
    base = baseline_seconds()
    print(f"baseline: one bare pipeline.identify on {BASELINE_PLANT} "
          f"({PLANTS[BASELINE_PLANT].formula}, seed 0, white): {base:.3f} s")
    t0 = time.perf_counter()
    if a.workers > 1:
        with ProcessPoolExecutor(a.workers) as pool:
            rows = list(pool.map(one, jobs, chunksize=4))
    else:
        rows = [one(j) for j in jobs]
    wall = time.perf_counter() - t0
    print(f"wall time {wall:.0f} s\n")
    cases, ok = report(rows, base)
    failures(rows)
    print(f"\nclaims (stable 100 %, Ms <= {MS_LIMIT:g} in >= {100 * MS_SHARE:.0f} %, no "
          f"'robust' above {MS_LIMIT:g}) {'hold in every case' if ok else 'FAIL in: '}"
          + ("" if ok else ", ".join(f"{c['plant']} {c['kind']}" for c in cases
                                      if not c["passed"])))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"baseline_seconds": base, "wall_seconds": wall, "cases": cases,
                       "rows": rows}, fh, default=str)


if __name__ == "__main__":
    main()
