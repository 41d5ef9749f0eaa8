"""Corpus rows for segmentation (issue 13 items 14 and 15): inputs whose events are odd."""

import json

import numpy as np

from pipeline import record as _record
from tests.corpus import Hostile, step_csv

IDENTIFY = ("identify", "log.csv", "--input", "u", "--output", "y", "--time", "time")


def _no_zero_height(folder):
    """The pulse inside the step is a pulse (area 1.5), no step of zero height, and no
    method failed (they divided by the zero step's du: "failed: internal error")."""
    rec = json.loads((folder / "rep" / "results.json").read_text())["records"][0]
    kinds = [(e["kind"], e["t0"]) for e in rec["events"]]
    assert kinds == [("step", 20.0), ("impulse", 60.0), ("step", 72.0)], kinds
    assert all(abs(e["u_ss"] - e["u0"]) >= 0.5 for e in rec["events"] if e["kind"] == "step")
    assert not [f for f in rec["fits"] if f["status"] == "failed"]


def _one_unsettled_step(folder):
    rec = json.loads((folder / "rep" / "results.json").read_text())["records"][0]
    assert [(e["kind"], e["settled"]) for e in rec["events"]] == [("step", False)]


def _scaled(text: str, factor: float) -> str:
    rows = text.splitlines()
    out = [rows[0]]
    for row in rows[1:]:
        t, u, y = row.split(",")
        out.append(f"{t},{float(u) * factor!r},{float(y) * factor!r}")
    return "\n".join(out) + "\n"


RAMP = "time,u,y\n" + "".join(f"{k * 0.5},{k * 0.01:.6g},{0.02 * k + 0.001 * np.sin(k):.6g}\n"
                              for k in range(400))

CASES = [
    # 0 -> 1 at t = 20, a 1.5 s pulse to 2 at t = 60, back to 1, 0 at t = 72
    Hostile("seg_pulse_inside_step", IDENTIFY + ("--events", "all", "--out", "rep"), 0,
            files={"log.csv": step_csv(dt=0.5, steps=((20.0, 1.0), (60.0, 2.0), (61.5, 1.0),
                                                      (72.0, 0.0)))},
            max_lines=0, check=_no_zero_height),
    Hostile("seg_constant_input", IDENTIFY, 2, files={"log.csv": step_csv(steps=())},
            stderr=("log.csv", "no step or impulse event found in the input 'u'"),
            max_lines=1),
    Hostile("seg_input_only_ramps", IDENTIFY + ("--out", "rep"), 0, files={"log.csv": RAMP},
            max_lines=0, check=_one_unsettled_step),
]

if hasattr(_record, "LARGEST_VALUE"):  # the loader refuses values past it (one line)
    CASES.append(Hostile("seg_values_1e300", ("segment", *IDENTIFY[1:]), 2,
                         files={"log.csv": _scaled(step_csv(), 1e300)}, stderr=("log.csv",)))
else:  # segmentation scales them (exactly): the events, and not a warning on stderr
    CASES.append(Hostile("seg_values_1e300", ("segment", *IDENTIFY[1:]), 0,
                         files={"log.csv": _scaled(step_csv(), 1e300)}, max_lines=0))
