"""Verdicts and recommendations against the truth on the Monte Carlo sets (issue 27).

    python benchmarks/verdict_calibration.py [--seeds 30] [--workers 2] [--plants a,b]
                                             [--kinds white,ar1,pink] [--levels 0.005,0.02]
                                             [--windows 3,6] [--out rows.json]

Every plant of :data:`pipeline.synth.montecarlo.PLANTS` under every condition (noise
colour x level x window), ``--seeds`` records each (:func:`pipeline.synth.montecarlo.
mc_record`), analysed as ``pipeline identify`` does (event 0 identifies, the others
validate). Per record: the recommended method, structure and verdict, its flags, and its
score against the truth (:func:`pipeline.synth.montecarlo.score`). Prints the rates the
issue names (recommended "ok", step response within 3 %, true structure) by noise colour
and by plant, the confusion table of verdict against right / wrong, and the flags that
keep right models from "ok". ``--out`` keeps the rows (JSON) for a closer look.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import platform
import subprocess
import time
from concurrent.futures import ProcessPoolExecutor

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.synth.montecarlo import NOISE_KINDS, PLANTS, Condition, mc_record, score


def one(args: tuple[str, Condition, int]) -> dict:
    name, cond, seed = args
    plant = PLANTS[name]
    rec = mc_record(plant, cond, seed)
    res = analyse(rec, AnalysisOptions())
    fit = res.recommended
    oracle = res.fit(f"lsq_{plant.model.structure}", 0, ())  # the truth's own structure
    row = {"plant": name, "kind": cond.kind, "level": cond.level, "window": cond.window,
           "seed": seed, "error": res.error, "oracle_right": bool(
               oracle is not None and oracle.ok and score(oracle.model, plant, cond).right)}
    if fit is None:
        return {**row, "verdict": "none", "right": False, "structure_ok": False}
    s = score(fit.model, plant, cond)
    return {**row, "method": fit.method, "structure": fit.model.structure,
            "params": fit.model.params, "verdict": fit.verdict,
            "flags": [f.code for f in fit.flags] + [f.code for f in res.flags],
            "step_error": s.error, "right": s.right, "structure_ok": s.structure}


def rate(rows: list[dict], key) -> str:
    n = len(rows)
    return f"{sum(1 for r in rows if key(r)) / n:6.1%}" if n else "     -"


def report(rows: list[dict]) -> None:
    def ok(r):
        return r["verdict"] == "ok"

    print(f"\n{len(rows)} records\n")
    print("| set | n | recommended ok | step within 3 % | true structure | wrong and ok "
          "| true structure's refinement within 3 % |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    groups = [("all", rows)] + [(k, [r for r in rows if r["kind"] == k]) for k in NOISE_KINDS]
    groups += [(f"window {w:g}T", [r for r in rows if r["window"] == w])
               for w in sorted({r["window"] for r in rows})]
    groups += [(f"{k} {lv:.1%}", [r for r in rows if r["kind"] == k and r["level"] == lv])
               for k in NOISE_KINDS for lv in sorted({r["level"] for r in rows})]
    groups += [(p, [r for r in rows if r["plant"] == p]) for p in PLANTS
               if any(r["plant"] == p for r in rows)]
    for name, part in groups:
        if part:
            print(f"| {name} | {len(part)} | {rate(part, ok)} | {rate(part, lambda r: r['right'])}"
                  f" | {rate(part, lambda r: r['structure_ok'])} | "
                  f"{rate(part, lambda r: ok(r) and not r['right'])} | "
                  f"{rate(part, lambda r: r['oracle_right'])} |")
    print("\nconfusion (verdict x right/wrong):")
    conf = collections.Counter((r["verdict"], "right" if r["right"] else "wrong") for r in rows)
    for v in ("ok", "warning", "unreliable", "none"):
        print(f"  {v:10s} right {conf[(v, 'right')]:5d}  wrong {conf[(v, 'wrong')]:5d}")
    flags = collections.Counter(f for r in rows if r["right"] and not ok(r)
                                for f in set(r.get("flags", [])))
    print("\nflags on right models that are not ok:", dict(flags.most_common(12)))
    wrong = collections.Counter(r.get("structure") for r in rows if not r["right"])
    print("structures of wrong recommendations:", dict(wrong.most_common(8)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--plants", default=",".join(PLANTS))
    ap.add_argument("--kinds", default=",".join(NOISE_KINDS))
    ap.add_argument("--levels", default="0.005,0.02")
    ap.add_argument("--windows", default="3,6")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    conds = [Condition(k, float(lv), float(w)) for k in a.kinds.split(",")
             for lv in a.levels.split(",") for w in a.windows.split(",")]
    jobs = [(p, c, s) for p in a.plants.split(",") for c in conds for s in range(a.seeds)]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    print(f"{len(jobs)} records at {commit}; {a.workers} workers; {platform.machine()}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}")
    t0 = time.perf_counter()
    with ProcessPoolExecutor(a.workers) as pool:
        rows = list(pool.map(one, jobs, chunksize=8))
    print(f"{time.perf_counter() - t0:.0f} s")
    report(rows)
    if a.out:
        with open(a.out, "w") as fh:
            json.dump(rows, fh)


if __name__ == "__main__":
    main()
