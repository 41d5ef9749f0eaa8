"""How far a change moves every refined parameter on the real logs (issue 30's condition
on result changes: at most 0.2 of its 95 % half-width).

    python benchmarks/refinement_moves.py --out before.json      # on the old code
    python benchmarks/refinement_moves.py --out after.json       # on the new code
    python benchmarks/refinement_moves.py --compare before.json after.json

Every log of :data:`real_logs.LOGS` is analysed with ``--events 0`` and ``--events all``
(tuning off: only the models). ``--out`` keeps each ok refinement's parameters, their
95 % intervals and its fit error. ``--compare`` prints, per parameter, the move over the
old interval's half-width (the larger of the two sides), the largest first, and a line per
fit whose error changed by more than 1e-6 relative (another basin, or a stop elsewhere):
which of the two is lower.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from real_logs import LOGS  # noqa: E402

from pipeline.analysis import AnalysisOptions, analyse  # noqa: E402
from pipeline.api import load  # noqa: E402

LIMIT = 0.2


def collect(datasets: Path) -> dict:
    out = {}
    for name, (path, data) in LOGS.items():
        record = load(datasets / path, **data)
        for events in ((0,), "all"):
            res = analyse(record, AnalysisOptions(events=events, tuning=None))
            for f in res.fits:
                if not (f.ok and f.is_refined):
                    continue
                key = f"{name} | {'all' if events == 'all' else '0'} | {f.method} | " \
                      f"{f.event} | {','.join(map(str, f.events))}"
                out[key] = {"params": dict(f.model.params),
                            "ci": {k: list(v) for k, v in (f.ci95 or {}).items()},
                            "mse": f.refinement.mse_fit}
    return out


def half_width(value: float, ci) -> float:
    if not ci:
        return math.nan
    lo, hi = ci
    return max(abs(value - lo), abs(hi - value))


def compare(a: dict, b: dict) -> int:
    moves, basins = [], []
    for key, x in a.items():
        y = b.get(key)
        if y is None:
            basins.append(f"{key}: gone")
            continue
        for n, v in x["params"].items():
            w = half_width(v, x["ci"].get(n))
            d = abs(y["params"].get(n, math.nan) - v)
            ratio = d / w if w > 0 and math.isfinite(w) else (0.0 if d == 0 else math.inf)
            moves.append((ratio, key, n, v, y["params"].get(n), w))
        ea, eb = x["mse"], y["mse"]
        if abs(eb - ea) > 1e-6 * abs(ea):
            basins.append(f"{key}: mse {ea:.6g} -> {eb:.6g} "
                          f"({'new' if eb < ea else 'old'} lower)")
    moves.sort(key=lambda m: -m[0] if math.isfinite(m[0]) else -1e300)
    over = [m for m in moves if not m[0] <= LIMIT]
    print(f"{len(moves)} parameters of {len(a)} fits; over {LIMIT} of the half-width: "
          f"{len(over)}")
    for r, key, n, v, w_new, w in moves[:15]:
        print(f"  {r:8.3g}  {key} | {n}: {v:.6g} -> {w_new:.6g} (half-width {w:.3g})")
    print(f"fits whose error changed: {len(basins)}")
    for line in basins:
        print("  " + line)
    return len(over)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=Path,
                    default=Path(__file__).resolve().parents[2] / "shared" / "datasets")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--compare", nargs=2, type=Path)
    a = ap.parse_args()
    if a.compare:
        compare(*(json.loads(p.read_text()) for p in a.compare))
        return
    a.out.write_text(json.dumps(collect(a.datasets), indent=1))


if __name__ == "__main__":
    main()
