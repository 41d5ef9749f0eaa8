"""Hostile time grids for the simulator (issue 13 item 16): a bimodal grid (bursts of 1 ms
samples between 0.9 s gaps) used to send every simulation to a 0.25 ms uniform grid over
the whole record (5 minutes and 2.1 GB for a 300 kB CSV); it is now simulated exactly in
O(samples) and the record identifies like any other."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from . import Hostile


def _bimodal_csv(n: int = 1500) -> str:
    rng = np.random.default_rng(5)
    t = np.concatenate([[0.0], np.cumsum(np.where(rng.random(n - 1) < 0.5, 0.001, 0.9))])
    ts = t[n // 3]
    u = np.where(t >= ts, 1.0, 0.0)
    y = np.where(t >= ts, 2.0 * -np.expm1(-(t - ts) / 60.0), 0.0) + rng.normal(0, 0.01, n)
    rows = "".join(f"{a:.6f},{b:g},{c:.6g}\n" for a, b, c in zip(t, u, y, strict=True))
    return "time,u,y\n" + rows


def _gain_two(d: Path) -> None:
    doc = json.loads((d / "rep" / "results.json").read_text())
    fits = [f for r in doc["records"] for f in r["fits"] if f["status"] == "ok"]
    assert fits and all(abs(f["params"]["K"] - 2.0) < 0.05 for f in fits)


CASES: list[Hostile] = [
    Hostile("bimodal_time_grid",
            ("identify", "{d}/bimodal.csv", "--input", "u", "--output", "y", "--time", "time",
             "--method", "first_order,lsq_first_order", "--out", "{d}/rep"),
            0, files={"bimodal.csv": _bimodal_csv()}, check=_gain_two),
]
