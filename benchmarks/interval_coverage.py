"""Coverage of the 95 % intervals of K and the dominant time constant (issue 27 item 8).

    python benchmarks/interval_coverage.py [--seeds 10] [--workers 2] [--joint]

The refinement of each plant's true structure (``lsq_<structure>``, event 0 identifying)
on the Monte Carlo staircases of :mod:`pipeline.synth.montecarlo`: five plants (first
order with short and long delay, two lags, an equal-lag chain of three, an underdamped
pair, whose time constant is not a lag and is not counted), white, AR(1) (phi 0.9) and
1/f noise of 0.5 % and 2 %, windows of 3 T and 6 T, ``--seeds`` seeds. Prints, per noise
colour, how often the interval holds the truth, and the median of the squared
standardised error ``((estimate - truth) / sd)^2`` (about 0.45, the median of
chi-square with one degree of freedom, when the intervals are honest). ``--joint``: the
fit over every event instead (``--events all``; :mod:`pipeline.refine.fold_spread`), of
the first four plants, ``--first-seed`` on.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
from concurrent.futures import ProcessPoolExecutor

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.synth.montecarlo import NOISE_KINDS, PLANTS, Condition, mc_record

CASES = ("fopdt_delay0.05", "fopdt_delay0.5", "two_lags", "lags_3", "underdamped_0.6")
#: the dominant lag's parameter of each true structure (none: not a lag)
DOMINANT = {"first_order": "T", "two_lags": "T1", "n_lags": "T", "second_order": None}


def one(args: tuple[str, str, float, float, int, bool]
        ) -> tuple[str, list[tuple[str, bool, float]]]:
    """(noise colour, [(parameter, covered, squared standardised error)])."""
    name, kind, level, window, seed, joint = args
    plant = PLANTS[name]
    truth = plant.model
    rec = mc_record(plant, Condition(kind, level, window), seed)
    method = f"lsq_{truth.structure}"
    res = analyse(rec, AnalysisOptions(methods=(method,), consistency=False, tuning=None,
                                       events="all" if joint else (0,)))
    fit = next((f for f in res.fits if f.method == method and f.ok
                and bool(f.events) == joint), None)
    out: list[tuple[str, bool, float]] = []
    if fit is None:
        return kind, out
    for label, par in (("K", "K"), ("T", DOMINANT[truth.structure])):
        if par is None or par not in fit.ci95:
            continue
        lo, hi = fit.ci95[par]
        value, true = fit.model.params[par], truth.params[par]
        sd = fit.refinement.std.get(par) if fit.refinement else None
        z2 = ((value - true) / sd) ** 2 if sd else float("nan")
        out.append((label, lo <= true <= hi, z2))
    return kind, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--joint", action="store_true", help="the fits over every event")
    ap.add_argument("--first-seed", type=int, default=0)
    a = ap.parse_args()
    cases = CASES[:4] if a.joint else CASES
    jobs = list(itertools.product(cases, NOISE_KINDS, (0.005, 0.02), (3.0, 6.0),
                                  range(a.first_seed, a.first_seed + a.seeds), (a.joint,)))
    rows: dict[tuple[str, str], list[tuple[bool, float]]] = {}
    with ProcessPoolExecutor(a.workers) as pool:
        for kind, out in pool.map(one, jobs, chunksize=4):
            for label, covered, z2 in out:
                rows.setdefault((kind, label), []).append((covered, z2))
    print("| noise | parameter | fits | covered | median z^2 |\n|---|---|---:|---:|---:|")
    for (kind, label), v in sorted(rows.items()):
        cov = sum(c for c, _ in v) / len(v)
        z2 = statistics.median([z for _, z in v if z == z] or [float("nan")])  # no NaN
        print(f"| {kind} | {label} | {len(v)} | {cov:.1%} | {z2:.2f} |")


if __name__ == "__main__":
    main()
