"""The recommendation and its verdict on every real log in ``../shared/datasets/`` (issue 27).

    python benchmarks/real_logs.py [--datasets ../shared/datasets]

Each log is analysed as ``pipeline identify`` does, once with event 0 identifying (the
others validate) and once with every event identifying (held-out errors by
cross-validation). Prints one Markdown row per log and mode: the recommended method and
model, its verdict and flags, and how it scores on the data it did not see (validation
fit %, held-out MSE); then whether the two modes give the same model and verdict.
Nobody here wrote these logs, so there is no truth to score against: the table is what a
user would see, and the note says which models are right.

    python benchmarks/real_logs.py --tuning

prints instead the controller tuned (SIMC, the defaults of ``pipeline run``) from each
log's recommended model with event 0 identifying: the settings in the ideal form, the
margins with the exact dead time, the worst case over the model's 95 % intervals, the
verdict, and the time the tuning took against the time of the analysis without it
(measured in the same run).
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from pathlib import Path

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.api import load

#: log -> (file below the datasets folder, the data keys to load it with)
LOGS = {
    "daisy heating": ("daisy/heating_system.dat", {"input": 1, "output": 2, "time": 0,
                                                    "initial_input": 6.0}),
    "tclab kantor": ("tclab-kantor/step_test_data.csv", {"input": "Q1", "output": "T1",
                                                          "time": "Time", "initial_input": 0.0}),
    "apmonitor step": ("apmonitor-tclab/data_step_test.csv", {"input": 1, "output": 2,
                                                               "time": 0, "header": False}),
    "apmonitor degF": ("apmonitor-tclab/degF_data.csv", {"input": "voltage",
                                                         "output": "temperature",
                                                         "time": "time"}),
    "apmonitor two heaters": ("apmonitor-tclab/mimo_data.txt", {"input": 1, "output": 3,
                                                                "time": 0}),
    "dc motor": ("daniw-rt-l/dc_step_5_15_05.mat", {"input": "Motorspannung",
                                                    "output": "Geschwindigkeit",
                                                    "time": "Zeit"}),
    "air duct": ("daniw-rt-l/air_step_1_5_45.mat", {"input": "Heizung", "output": "Temperatur",
                                                    "time": "Zeit"}),
    "tank step": ("daniw-rt-l/niveau_step_5_55.mat", {"input": "PumpeRechts",
                                                      "output": "NiveauTank2", "time": "Zeit"}),
    "tank pulse": ("daniw-rt-l/niveau_impulse_0_10_0.mat", {"input": "PumpeRechts",
                                                            "output": "NiveauTank2",
                                                            "time": "Zeit"}),
    "pipe": ("ulg-pipe/PipeDataULg151204_1.data.txt", {"input": 5, "output": 3, "time": 0,
                                                       "header": False}),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=Path,
                    default=Path(__file__).resolve().parents[2] / "shared" / "datasets")
    ap.add_argument("--tuning", action="store_true", help="the tuned controllers instead")
    a = ap.parse_args()
    if a.tuning:
        tuning_table(a.datasets)
        return
    print("| log | events | recommended | model | verdict | flags | validation fit % | "
          "held-out MSE |")
    print("|---|---|---|---|---|---|---:|---:|")
    same = []
    for name, (path, data) in LOGS.items():
        record = load(a.datasets / path, **data)
        seen = []
        for events in ((0,), "all"):
            res = analyse(record, AnalysisOptions(events=events))
            fit = res.recommended
            label = "all" if events == "all" else "0"
            if fit is None:
                flags = ", ".join(f.code for f in res.flags) or res.error or "-"
                print(f"| {name} | {label} | none | - | - | {flags} | - | - |")
                seen.append(None)
                continue
            flags = ", ".join(f"{f.code}{' (info)' if f.severity == 'info' else ''}"
                              for f in fit.flags) or "-"
            m = fit.metrics
            held = m.get("mse_validation" if res.validation_events else
                         "mse_cross_validation", float("nan"))
            print(f"| {name} | {label} | {fit.method} | "
                  f"`{fit.model.text(3)}` | {fit.verdict} | {flags} | "
                  f"{m.get('fit_percent', float('nan')):.1f} | {held:.4g} |")
            seen.append((fit.method, fit.event, tuple(fit.events), fit.verdict))
        same.append((name, seen[0] == seen[1]))
    print("\nthe same model and verdict with --events 0 and --events all:",
          ", ".join(f"{n}: {'yes' if s else 'no'}" for n, s in same))


def _g(v: float | None, digits: int = 3) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.{digits}g}"


def tuning_table(datasets: Path) -> None:
    """One Markdown row per log: the tuned controller of its recommended model."""
    from pipeline.analysis import tuned
    from pipeline.tuning import TuningOptions

    print(f"machine: {platform.processor() or platform.machine()}, {platform.system()}, "
          f"Python {platform.python_version()}\n")
    print("| log | model | controller | Kc | Ti | Td | Ms | GM | PM | DM | worst Ms "
          "(sets) | verdict | tuning / analysis time |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|")
    for name, (path, data) in LOGS.items():
        record = load(datasets / path, **data)
        t0 = time.perf_counter()
        res = analyse(record, AnalysisOptions(events=(0,), tuning=None))
        t_analysis = time.perf_counter() - t0
        t0 = time.perf_counter()
        rt = tuned(res, TuningOptions()) if res.recommended is not None else None
        t_tuning = time.perf_counter() - t0
        if rt is None or not rt.ok:
            why = "no recommended model" if rt is None else rt.reason
            print(f"| {name} | {res.recommended.method if res.recommended else '-'} | "
                  f"not tuned: {why} | | | | | | | | | | |")
            continue
        t, c, m, w = rt.tuning, rt.tuning.controller, rt.tuning.margins, rt.tuning.worst
        worst = f"{_g(w.ms)} ({w.n_sets})" if w is not None else "-"
        print(f"| {name} | {res.recommended.method} | {c.kind} ({t.action}) | "
              f"{_g(c.Kc, 4)} {rt.gain_unit} | {_g(c.Ti, 4)} | {_g(c.Td, 4)} | "
              f"{_g(m.ms)} | {_g(m.gain_margin)} | {_g(m.phase_margin)} | "
              f"{_g(m.delay_margin)} | {worst} | {t.verdict} | "
              f"{t_tuning * 1e3:.0f} ms / {t_analysis * 1e3:.0f} ms "
              f"({t_tuning / t_analysis:.2f}) |")


if __name__ == "__main__":
    main()
