"""The floor each refinement is measured against (issue 30 item 1): a lean least-squares
fit of one event, against the tool's ``lsq_<structure>`` on the same events.

    python benchmarks/lean_reference.py [--events 40] [--structures first_order,...]

The reference is what a careful engineer would write for one event and one structure:

* the exact ZOH simulation of the structure from rest (the same simulator as the tool,
  :func:`pipeline.simulation.forced_response`: the recursion is the arithmetic any
  implementation does);
* the gain and the offset (and a zero's ``K Tz``, which enters linearly) solved by linear
  least squares inside the residual (variable projection), so the search sees only the
  lags, the damping, the order and the dead time, on log scale where positive;
* one start: the structure's first template (:func:`pipeline.refine.search.templates`)
  at the first-order graphical reading's time scale and dead time;
* ``scipy.optimize.least_squares`` (trust-region reflective, bounded, the tool's
  tolerances), forward-difference Jacobian (a forward-sensitivity Jacobian of the
  recursion, prototyped on these events, cost 0.83x the differences: the evaluations'
  set-up, not the filtering, is the cost at 5,000 samples);
* no decimation, no second start, no basin check, no intervals.

For each structure a record of ``--events`` steps of 5,000 samples each is made from a
plant *of that structure* (1 % white noise, dead time 3 samples), so that both fits have
one right answer. Each event is fitted by both, one BLAS thread, CPU time per fit
(``time.process_time``). Printed per structure: the medians, the ratio tool / reference
(the issue's target is at most 1.5), and how often each found the lower error (a fit more
than 1e-6 relative above the other's error is in another basin, or stopped early).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from pipeline.events import EventData  # noqa: E402
from pipeline.methods import identify  # noqa: E402
from pipeline.models import STRUCTURES, ProcessModel  # noqa: E402
from pipeline.record import make_record  # noqa: E402
from pipeline.refine.search import FTOL, search_space, templates  # noqa: E402
from pipeline.segmentation.detect import segment  # noqa: E402
from pipeline.simulation import forced_response, simulate  # noqa: E402
from pipeline.validate import fit_start  # noqa: E402

DT = 0.1
WINDOW = 5000
#: The plants, their time scale an eighth of a window (500 samples).
TS = WINDOW * DT / 8
PLANTS = {
    "first_order": {"K": 2.0, "T": TS, "delay": 3 * DT},
    "second_order": {"K": 2.0, "zeta": 0.5, "wn": 1.0 / (TS / 2), "delay": 3 * DT},
    "two_lags": {"K": 2.0, "T1": TS * 0.7, "T2": TS * 0.2, "delay": 3 * DT},
    "n_lags": {"K": 2.0, "T": TS / 3, "n": 3.0, "delay": 3 * DT},
    "zero_two_lags": {"K": 2.0, "Tz": TS * 0.3, "T1": TS * 0.7, "T2": TS * 0.2,
                      "delay": 3 * DT},
    "lead_lag": {"K": 2.0, "Tz": TS * 0.4, "T": TS, "delay": 3 * DT},
}
#: Parameters the response is affine in (solved linearly, as the tool does).
LINEAR = ("Tz",)


def record(structure: str, n_events: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    n = WINDOW * (n_events + 1)
    levels = 5.0 + (-1.0) ** np.arange(n_events) * rng.uniform(0.6, 1.4, n_events)
    u = np.full(n, 5.0)
    for k in range(n_events):
        u[(k + 1) * WINDOW:] = levels[k]
    t = np.arange(n) * DT
    y = simulate(ProcessModel(structure, PLANTS[structure]), t, u, 5.0, 20.0, dt=DT)
    y += rng.normal(0.0, 0.01 * 2.0, n)
    return make_record(t, u, y, name=structure, source=f"<{structure}>")


def lean_fit(structure: str, t, u, y, u_ref: float, start: dict[str, float]
             ) -> tuple[dict[str, float], float, int]:
    """``(parameters, MSE, residual evaluations)`` of the lean reference (module docstring)."""
    spec = STRUCTURES[structure]
    names = [n for n in spec.params if n != "K" and n not in LINEAR]
    linear = [n for n in spec.params if n in LINEAR]
    span = float(t[-1] - t[0])
    space = search_space(structure, names, DT, span)
    ones = np.ones(t.size)

    def design(z):
        p = {**dict.fromkeys(linear, 0.0), **space.from_z(z)}
        x0 = forced_response(structure, p, t, u, DT, u0=u_ref)
        cols = [x0]
        for n in linear:  # the change per unit of each linear parameter
            cols.append(forced_response(structure, {**p, n: 1.0}, t, u, DT, u0=u_ref) - x0)
        return np.column_stack([*cols, ones])

    def residual(z):
        a = design(z)
        c = np.linalg.lstsq(a, y, rcond=None)[0]
        r = y - a @ c
        return r if np.all(np.isfinite(r)) else np.full(y.size, 1e150)

    z0 = space.to_z({n: start[n] for n in names})
    res = least_squares(residual, z0, bounds=(space.lo, space.hi), method="trf",
                        ftol=FTOL, xtol=FTOL, max_nfev=300)
    p = space.from_z(res.x)
    if "n" in names:  # a rational chain: the better integer order, the rest polished
        best = None
        for n_int in {math.floor(p["n"]), math.ceil(p["n"])}:
            n_int = float(min(max(n_int, 1), 20))
            sub = [m for m in names if m != "n"]
            sp = search_space(structure, sub, DT, span)

            def r_n(z, n_int=n_int, sp=sp):
                q = {**sp.from_z(z), "n": n_int}
                a = np.column_stack([forced_response(structure, q, t, u, DT, u0=u_ref), ones])
                return y - a @ np.linalg.lstsq(a, y, rcond=None)[0]

            rr = least_squares(r_n, sp.to_z(p), bounds=(sp.lo, sp.hi), method="trf",
                               ftol=FTOL, xtol=FTOL, max_nfev=300)
            if best is None or rr.cost < best[1].cost:
                best = ({**sp.from_z(rr.x), "n": n_int}, rr)
        p, res2 = best
        return p, 2 * res2.cost / y.size, res.nfev + res2.nfev
    return p, 2 * res.cost / y.size, res.nfev


def measure(structure: str, n_events: int) -> dict:
    rec = record(structure, n_events)
    evs = [EventData.from_event(rec, e) for e in segment(rec)[1:n_events + 1]]
    tool_ms, ref_ms, tool_better, ref_better = [], [], 0, 0
    for ev in evs:
        fo = identify(ev, "first_order")
        models = [f.model for f in (fo, identify(ev, "viteckova1")) if f.ok]
        c = time.process_time()
        fit = identify(ev, f"lsq_{structure}", models=models, state="rest")
        tool_ms.append(1e3 * (time.process_time() - c))
        sl = slice(fit_start(0, ev.i0, ev.t.size), ev.t.size)
        tau = fo.model.time_scale if fo.ok else TS
        delay = fo.model.delay if fo.ok else 0.0
        start = templates(structure, tau, delay)[0]
        c = time.process_time()
        _, mse_ref, _ = lean_fit(structure, ev.t[sl], ev.u[sl], ev.y[sl], ev.u0, start)
        ref_ms.append(1e3 * (time.process_time() - c))
        mse_tool = fit.refinement.mse_fit if fit.ok else math.inf
        if mse_tool > mse_ref * (1 + 1e-6):
            ref_better += 1
        elif mse_ref > mse_tool * (1 + 1e-6):
            tool_better += 1
    return {"tool": statistics.median(tool_ms), "ref": statistics.median(ref_ms),
            "ratio": statistics.median(a / b for a, b in zip(tool_ms, ref_ms, strict=True)),
            "tool_better": tool_better, "ref_better": ref_better, "n": len(evs)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--events", type=int, default=40)
    ap.add_argument("--structures", default=",".join(PLANTS))
    a = ap.parse_args()
    print(f"{platform.processor() or platform.machine()}, CPython "
          f"{platform.python_version()}, {os.cpu_count()} CPU(s), one BLAS thread; "
          f"{a.events} events of {WINDOW} samples per structure\n")
    print("| structure | tool (ms) | reference (ms) | tool / reference (median of "
          "pairs) | lower error: tool / reference / tie |")
    print("|---|---:|---:|---:|---|")
    for s in a.structures.split(","):
        m = measure(s, a.events)
        tie = m["n"] - m["tool_better"] - m["ref_better"]
        print(f"| {s} | {m['tool']:.1f} | {m['ref']:.1f} | {m['ratio']:.2f} | "
              f"{m['tool_better']} / {m['ref_better']} / {tie} |", flush=True)


if __name__ == "__main__":
    main()
