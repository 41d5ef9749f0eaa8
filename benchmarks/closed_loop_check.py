"""How often the closed-loop check fires on closed loops and on open-loop tests (issue 27
item 5).

    python benchmarks/closed_loop_check.py [--seeds 3] [--base REV]

Closed loops (:func:`pipeline.synth.closed_loop.loop_record`): every plant and controller
of ``LOOP_TUNINGS`` (first order with delay, two lags, an integrator with a lag, an
open-loop-unstable lag, the same behind a second lag; P, PI and PID as SIMC tunes them,
and detuned 2x), setpoint steps and load steps at a fixed setpoint, measurement noise of
1 % and 3 % of the setpoint step (white and AR(1) 0.9) and none, the controller output
logged as the input. Open-loop tests: a first-order plant with delay/T 0.1 to 5 under
steps ramped over 0 to 3 T, white, AR(1) and 1/f noise, the output also quantised
as a real pipe's logger does; fast plants (T of one or two samples, gains of both
signs) logged in the sample they answer in, with and without input noise; and the
Monte Carlo staircases of ``pipeline.synth.montecarlo.PLANTS``. Prints the share
flagged per set and the cases that went the wrong way. ``--base REV`` runs the check of
that commit (a worktree) on the same records, for the before/after figures.
"""

from __future__ import annotations

import argparse
import atexit
import collections
import importlib
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.synth.closed_loop import LOOP_TUNINGS, loop_record
from pipeline.synth.montecarlo import NOISE_KINDS, PLANTS, Condition, mc_record, noise
from pipeline.synth.plants import ramped_staircase, response

LOADS = ((20.0, 2.0), (120.0, -3.0), (220.0, 1.5))


def closed_loops(seeds: int):
    """(set, name, record) of every closed loop of the bench."""
    for plant, controllers in LOOP_TUNINGS.items():
        for ctrl in controllers:
            for detune in (1.0, 2.0):
                for signal in ("setpoint", "load"):
                    kw = {"setpoints": (), "loads": LOADS} if signal == "load" else {}
                    for phi in (0.0, 0.9):
                        for level in (0.0, 0.01, 0.03):
                            for s in range(seeds if level else 1):
                                rec = loop_record(plant, ctrl, detune=detune, noise=5 * level,
                                                  noise_phi=phi, seed=s, **kw)
                                label = "noise-free" if not level else \
                                    f"{'AR(1)' if phi else 'white'} noise"
                                yield (f"closed, {label}",
                                       f"{plant} {ctrl} x{detune:g} {signal}", rec)


def open_loops(seeds: int):
    """(set, name, record) of every open-loop test of the bench."""
    changes = [(20.0, 5.0), (120.0, 3.0), (220.0, 4.5), (320.0, 2.5)]
    t = np.arange(0.0, 400.0, 0.5)
    for ratio in (0.1, 0.5, 1.0, 2.0, 5.0):
        model = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 10.0 * ratio})
        for ramp in (0.0, 3.0, 10.0, 30.0):
            u = ramped_staircase(t, 2.0, changes, ramp)
            clean = response(model, t, u, 2.0, 7.0)
            for kind in NOISE_KINDS:
                for s in range(seeds + 1):
                    y = clean + noise(kind, t.size, 0.06, np.random.default_rng(s))
                    for quant in (False, True):
                        yq = np.round(y / 0.1) * 0.1 if quant else y
                        yield ("open, delays and ramps",
                               f"delay/T {ratio:g} ramp {ramp:g} {kind}"
                               + (" quantised" if quant else ""),
                               make_record(t, u, yq, name="x", source="<bench>"))
    tf = np.arange(0.0, 100.0, 0.5)
    for K in (2.0, -2.0):
        for T in (0.3, 1.0):
            model = ProcessModel("first_order", {"K": K, "T": T, "delay": 0.0})
            for kind in NOISE_KINDS:
                for ramp in (0.0, 1.0, 3.0):
                    for s in range(seeds + 1):
                        u = ramped_staircase(tf, 2.0, [(10.0, 5.0), (40.0, 3.0), (70.0, 4.5)],
                                             ramp)
                        if s % 2:
                            u = u + np.random.default_rng(50 + s).normal(0.0, 0.1, tf.size)
                        y = response(model, tf, u, 2.0, 7.0) + noise(
                            kind, tf.size, 0.03, np.random.default_rng(s))
                        # logged as a sensor reads it: the input of the interval that ends
                        # at the sample, so the output answers in the same sample
                        yield ("open, fast plants logged in the same sample",
                               f"K {K:g} T {T:g} {kind} ramp {ramp:g}",
                               make_record(tf, np.r_[u[0], u[:-1]], y, name="x",
                                           source="<bench>"))
    for name, plant in PLANTS.items():
        for kind in NOISE_KINDS:
            for level in (0.005, 0.02):
                for s in range(seeds):
                    yield ("open, Monte Carlo staircases", f"{name} {kind} {level:g}",
                           mc_record(plant, Condition(kind, level, 4.0), s))


def tally(check, records) -> dict:
    """Per set: [records, flagged, names of the wrong-way cases]."""
    out: dict = collections.defaultdict(lambda: [0, 0, collections.Counter()])
    for group, name, rec in records:
        hit = check(rec, []) is not None
        row = out[group]
        row[0] += 1
        row[1] += hit
        if hit != group.startswith("closed"):
            row[2][name] += 1
    return out


def base_check(rev: str):
    """The closed-loop check as commit ``rev`` has it (imported from a worktree)."""
    folder = Path(tempfile.mkdtemp(prefix="closed-loop-base-"))
    subprocess.run(["git", "worktree", "add", "--detach", str(folder), rev], check=True,
                   capture_output=True)
    atexit.register(subprocess.run, ["git", "worktree", "remove", "--force", str(folder)],
                    capture_output=True)
    sys.path.insert(0, str(folder))
    for mod in [m for m in sys.modules if m == "pipeline" or m.startswith("pipeline.")]:
        del sys.modules[mod]
    return importlib.import_module("pipeline.grading.closed_loop").closed_loop_flag


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--base", help="also run the check of this commit")
    a = ap.parse_args()
    records = list(closed_loops(a.seeds)) + list(open_loops(a.seeds))
    from pipeline.grading.closed_loop import closed_loop_flag

    checks = [("this tree", closed_loop_flag)]
    if a.base:
        checks.append((a.base, base_check(a.base)))
    for label, check in checks:
        print(f"## {label}\n\n| set | records | flagged | wrong way |\n|---|---:|---:|---|")
        for group, (n, hits, wrong) in tally(check, records).items():
            worst = ", ".join(f"{k} ({v})" for k, v in wrong.most_common(4))
            print(f"| {group} | {n} | {hits / n:.1%} | {worst} |")
        print()


if __name__ == "__main__":
    main()
