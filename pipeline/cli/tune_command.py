"""``pipeline tune`` once its options are parsed: the controller from a results.json's
recommended models, or from a model given on the command line
(``pipeline tune first_order K=2 T=10 delay=1``)."""

from __future__ import annotations

import difflib
import math
from dataclasses import replace
from pathlib import Path

from ..errors import UserError
from ..models import STRUCTURES, ProcessModel
from ..tuning import (
    THROUGH_LOOP,
    RecordTuning,
    TuningOptions,
    model_trust,
    through_loop_trust,
    tune,
)


def parse_model(structure: str, assignments: list[str]) -> ProcessModel:
    """A model from ``first_order`` and ``["K=2", "T=10", "delay=1"]``; every problem is
    one line naming the argument and what was expected."""
    if structure not in STRUCTURES:
        near = difflib.get_close_matches(structure, list(STRUCTURES), n=1)
        hint = f" (did you mean {near[0]}?)" if near else ""
        raise UserError(f"{structure!r} is neither a results.json file nor a model "
                        f"structure{hint}; structures: {', '.join(STRUCTURES)}")
    spec = STRUCTURES[structure]
    params: dict[str, float] = {}
    for a in assignments:
        name, sep, value = a.partition("=")
        if not sep:
            raise UserError(f"{a!r}: expected NAME=VALUE, e.g. K=2 (parameters of "
                            f"{structure}: {', '.join(spec.params)})")
        name = name.strip()
        if name not in spec.params:
            raise UserError(f"{a!r}: {structure} has no parameter {name!r}; its parameters: "
                            f"{', '.join(spec.params)}")
        try:
            v = float(value)
        except ValueError:
            raise UserError(f"{a!r}: expected a number after '='") from None
        lo, hi = spec.bounds.get(name, (-math.inf, math.inf))
        if not math.isfinite(v) or not lo <= v <= hi or (lo == 0.0 and v == 0.0 and
                                                         name != "delay"):
            raise UserError(f"{a!r}: {name} must be a finite number in ({lo:g}, {hi:g})")
        params[name] = v
    missing = [p for p in spec.params if p != "delay" and p not in params]
    if missing:
        raise UserError(f"{structure} needs {', '.join(f'{m}=...' for m in missing)} "
                        f"(parameters: {', '.join(spec.params)})")
    return ProcessModel(structure, params)


def _from_results(path: Path, options: TuningOptions, record: str | None
                  ) -> list[tuple[str, RecordTuning]]:
    from ..gate import load_results

    doc = load_results(path)
    out = []
    names = [r.name for r in doc.records]
    if record is not None and record not in names:
        raise UserError(f"--record {record!r}: {path} has no such record; records: "
                        + ", ".join(names[:10]) + (" ..." if len(names) > 10 else ""))
    for r in doc.records:
        if record is not None and r.name != record:
            continue
        rec = r.recommended
        base = RecordTuning(method=rec.method if rec else "-", event=rec.event if rec else 0,
                            events=tuple(rec.events) if rec else (), rule=options.rule,
                            units=dict(r.units))
        if rec is None:
            out.append((r.name, RecordTuning(**{**base.__dict__,
                                                "reason": "no recommended model"})))
            continue
        plant = r.running_loop.plant if r.running_loop is not None else None
        if plant is None:
            model = ProcessModel(rec.structure, dict(rec.params))
            intervals = rec.ci95
            trusted, why = model_trust(rec.verdict, (f.code for f in (*rec.flags, *r.flags)),
                                       (f.code for f in rec.flags if f.severity == "warning"))
        else:  # a closed-loop log's plant fitted through its loop, as the run tuned it
            model = ProcessModel(plant.structure, dict(plant.params))
            intervals = plant.ci95
            trusted, why = through_loop_trust(f.code for f in r.flags)
            base = replace(base, method=THROUGH_LOOP, events=())
        ci95 = {k: (lo, hi) for k, (lo, hi) in intervals.items()
                if lo is not None and hi is not None}
        out.append((r.name, _tuned(base, model, options, ci95, trusted, why, note=(
            "results.json keeps the 95 % intervals but not the parameter covariance: the "
            "settings are checked on the box's corners only") if ci95 else "")))
    return out


def _tuned(base: RecordTuning, model: ProcessModel, options: TuningOptions, ci95,
           trusted: bool, why_not: str, note: str = "") -> RecordTuning:
    try:
        t = tune(model, options, ci95=ci95, trusted=trusted, why_not=why_not)
    except ValueError as exc:
        return RecordTuning(**{**base.__dict__, "reason": str(exc)})
    if note:
        t = replace(t, notes=(*t.notes, note))
    return RecordTuning(**{**base.__dict__, "tuning": t})


def tune_command(source: str, assignments: list[str], options: TuningOptions,
                 record: str | None = None, units: dict[str, str] | None = None
                 ) -> list[tuple[str, RecordTuning]]:
    """``(name, tuning)`` for each record of a results.json ``source``, or one for the
    model ``source`` and ``assignments`` describe."""
    path = Path(source)
    if path.suffix.lower() == ".json" or path.is_file():
        if assignments:
            raise UserError(f"unexpected argument {assignments[0]!r}: parameters go with a "
                            "model structure, not with a results.json file")
        return _from_results(path, options, record)
    if record is not None:
        raise UserError("--record goes with a results.json file, not with a model")
    model = parse_model(source, assignments)
    base = RecordTuning(method="(given)", event=0, rule=options.rule, units=units or {})
    return [(model.text(), _tuned(base, model, options, None, True,
                                  "a model given without intervals"))]
