"""Regression gate: compare a results.json object with a baseline one (pure functions).

Records are matched by ``name``, fits by ``(event, label)`` (the method, with the events of
a joint fit: :func:`pipeline.schema.fit_label`). :func:`compare` returns a
:class:`Comparison`; it is a regression (exit code 1 in the CLI) when any of these holds:

* **param_drift** - a parameter of a fit that is ok in both moved beyond its tolerance
  (and, for fits with 95 % intervals, beyond their combined half-widths; when the two
  models' step responses agree within the dynamics tolerance only the gain and the dead
  time are compared, since an over-parameterised fit trades its time constants freely).
  The change is relative, ``(current - baseline) / scale``, where ``scale`` is
  ``|baseline|`` except for parameters whose baseline may sensibly be zero or tiny:

  - ``delay`` and ``Tz`` are compared with the fit's time scale (the mean residence time
    of its lags: ``T``, ``T1 + T2``, ``n T``, ``max(2 zeta, 1)/wn``, plus ``-Tz`` for an
    inverse response; for an integrator the lag of its ramp, ``T + delay``), so a dead
    time of 0.0 that becomes 0.05 s on a 5 s lag is a 1 % change, not an infinite one;
  - ``T1``, ``T2`` are compared with the dominant lag ``max(T1, T2)``: a minor lag a
    tenth of the main one is poorly determined by a step, so its change is measured in
    units of the main lag;
  - ``zeta`` with ``max(|zeta|, 0.1)``.

  Tolerances: ``param_tols[name]`` when given, else ``param_tol`` for the parameters whose
  tolerance class is "gain" in :data:`pipeline.models.PARAMETERS` and
  ``dynamics_factor * param_tol`` for the "dynamics" ones; the scale of each parameter
  (its value, the model's time scale, the dominant lag, a floor) is in the same table.
  The factor (default 3, so 15 %) is calibrated on noise: a step test pins the gain to a
  ratio of two averaged plateaus, while the dynamics are read off a few samples of the
  transient. On first-order-plus-dead-time logs with white noise of 1 % of the step
  (:mod:`pipeline.synth.logs`; 8 plants, 12 fresh-noise logs each, all 132 ordered
  pairs, every step method), the gains stayed within 0.9 % while the time constants
  and dead times moved by up to 5 % (63 % point) and 9 % (two-point methods such as
  Viteckova's t33/t70): no drift was flagged at the defaults, and a 10 % gain drift was
  flagged for every method and plant (tests/test_baseline.py repeats both checks on a
  smaller sample).
* **structure** - a fit that is ok in both changed its model structure (e.g. Strejc's
  equal lags vs two lags): reported with ``parameter = "structure"`` and regressing when
  the unit-step responses differ, somewhere, by more than the dynamics tolerance of the
  baseline gain (structures near a method's decision boundary flip under noise while
  the response barely moves). When the new structure is a worse model, the validation
  MSE rule below flags it (Strejc on a plant whose Tu/Tn sits on the 0.104 boundary).
* **mse_growth** - the validation MSE grew beyond ``mse_tol`` (relative) *and* beyond
  the MSE that a parameter change within tolerance can cause: it is a regression when
  ``current > (1 + mse_tol) baseline + (param_tol * dy)^2``, where ``dy`` is the median
  output change of the record's step events. Validation MSE on noisy data is the noise
  variance plus the model error, and a fresh-noise fit moves the model error by several
  noise variances; the floor keeps that from flagging while a model that got worse by
  more than a ``param_tol`` gain error on every step still does. With no step events
  (impulses only) the floor is 0.
* **status** - a fit that was ok is now ``not_applicable`` or ``failed``, or a record
  that was ok has now failed.
* **tuning_drift** / **tuning_verdict** - the controller tuned from the recommended
  model moved (Kc, Ti, Td beyond tolerance and beyond their spread over the intervals)
  or its verdict got worse: :mod:`pipeline.gate.tuning_findings`.
* a closed-loop log's plant fitted through the loop drifted (a regression), or its running
  controller was retuned (information): :mod:`pipeline.gate.loop_findings`.
* **missing** - a record, or a fit that was ok, is in the baseline but not in the current
  results (``missing_is_regression=False`` only lists them).

Records and fits present now but not in the baseline, and fits or records that became
ok, are listed in ``new``: information, never a failure.

:func:`compare` takes two :class:`~pipeline.schema.ResultsDoc` (a plain dict is validated
into one first). Which baseline a run accepts (the same config, shared records and
methods), reading it and :func:`accept` (promote a results.json to be the baseline) are in
:mod:`pipeline.gate.baseline_file`, re-exported here.

The :class:`Comparison` also names each record's recommended model (this run's, else the
baseline's), so the report, the terminal and JUnit can say per record what drifted on the
model to use before the per-method detail (:meth:`Comparison.by_record`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..errors import UserError
from ..models import PARAMETERS, STRUCTURES, ProcessModel
from ..results import as_doc
from ..schema import FitDoc, RecordDoc, ResultsDoc
from .baseline_file import accept, load_baseline
from .findings import (
    Comparison,
    Finding,
    is_number,
    num_text,
    pct_text,
    recommended_fit,
    tag_recommended,
)
from .loop_findings import loop_findings
from .tuning_findings import tuning_findings

__all__ = ["Comparison", "Finding", "Tolerances", "accept", "compare", "load_baseline",
           "tolerance_problem"]


@dataclass(frozen=True)
class Tolerances:
    """The limits :func:`compare` applies (see the module docstring)."""

    param_tol: float = 0.05
    param_tols: Mapping[str, float] = field(default_factory=dict)
    dynamics_factor: float = 3.0
    mse_tol: float = 0.10
    missing_is_regression: bool = True
    #: "recommended": only the recommended model (its parameters, tuning, verdict,
    #: validation error) and the records gate; other methods' changes are information.
    #: "all": every method's too.
    scope: Literal["recommended", "all"] = "recommended"

    def __post_init__(self) -> None:
        if self.scope not in ("recommended", "all"):
            raise UserError(f"gate scope {self.scope!r}: expected recommended or all")
        named = {"param_tol": self.param_tol, "mse_tol": self.mse_tol,
                 "dynamics_factor": self.dynamics_factor,
                 **{f"tolerance of {k}": v for k, v in self.param_tols.items()}}
        for name, v in named.items():
            problem = tolerance_problem(name, v)
            if problem:
                raise UserError(problem)

    def for_param(self, name: str) -> float:
        if name in self.param_tols:
            return float(self.param_tols[name])
        gain = name in PARAMETERS and PARAMETERS[name].tolerance == "gain"
        return self.param_tol * (1.0 if gain else self.dynamics_factor)

    @property
    def dynamics(self) -> float:
        return self.param_tol * self.dynamics_factor


def tolerance_problem(name: str, value) -> str | None:
    """Why ``value`` is not a tolerance (NaN switches the gate off, a negative one fires on
    everything, infinity never fires), or None when it is one: a finite fraction >= 0."""
    if isinstance(value, int | float) and not isinstance(value, bool) and \
            math.isfinite(value) and value >= 0:
        return None
    return f"{name} is {value!r}; expected a finite fraction >= 0, e.g. 0.05"


# -- the comparison ----------------------------------------------------------------------

def compare(current: ResultsDoc | dict, baseline: ResultsDoc | dict,
            tol: Tolerances | None = None) -> Comparison:
    """Compare two results documents (see the module docstring for the rules)."""
    tol = tol or Tolerances()
    current, baseline = as_doc(current), as_doc(baseline)
    cur = {r.name: r for r in current.records}
    base = {r.name: r for r in baseline.records}
    recommended = {name: recommended_fit(cur.get(name), base.get(name))
                   for name in {**base, **cur}}
    found: list[Finding] = []
    for name, b in base.items():
        found.extend(_compare_record(name, cur.get(name), b, tol))
    found.extend(_new_item(name, None, None, "record not in the baseline")
                 for name in cur if name not in base)
    found.extend(f for name, b in base.items() if name in cur
                 for f in recommended_findings(name, cur[name], b, tol))
    found = [tag_recommended(f, recommended) for f in found]
    missing = tuple(f for f in found if f.kind == "missing")
    failing = [f for f in found if f.kind not in ("new", "missing") or (
        f.kind == "missing" and tol.missing_is_regression and f.baseline_value == "ok")]
    other = [f for f in failing if tol.scope == "recommended" and f.method is not None
             and recommended.get(f.record) != (f.event, f.method)]
    kept = {id(f) for f in other}
    return Comparison(
        regressions=tuple(f for f in failing if id(f) not in kept),
        new=tuple(f for f in found if f.kind == "new"),
        missing=missing,
        other=tuple(other),
        settings={"param_tol": tol.param_tol, "param_tols": dict(tol.param_tols),
                  "dynamics_factor": tol.dynamics_factor, "mse_tol": tol.mse_tol,
                  "missing_is_regression": tol.missing_is_regression, "scope": tol.scope},
        recommended={k: v for k, v in recommended.items() if v is not None},
    )


#: A recommended model's verdict that is a regression to reach from ok or warning: the
#: model is not to be used. ok -> warning is information (a warning limits a model that
#: is still the one to use, and flips with the noise near a flag's threshold).
UNUSABLE = "unreliable"


def recommended_findings(name: str, cur: RecordDoc, base: RecordDoc, tol: Tolerances
                         ) -> list[Finding]:
    """What changed about a record's answer (both runs ok): it has no recommended model
    now, the recommended model became unreliable, or another method is recommended with
    a model that is not equivalent (step responses further apart than the dynamics
    tolerance, or a gain beyond its tolerance and its intervals). Another method with an
    equivalent model is information, not a regression."""
    if base.status != "ok" or cur.status != "ok" or base.recommended is None:
        return []
    b, c = base.recommended, cur.recommended
    if c is None:
        return [Finding(name, None, None, "recommended", "recommended", b.label, None,
                        message=f"{name}: no recommended model now (was {b.label}, event "
                                f"{b.event}); {cur.error or 'see the flags of the record'}")]
    where = f"{name} event {c.event} {c.label}"
    out = []
    if c.verdict == UNUSABLE and b.verdict != UNUSABLE:
        out.append(Finding(name, c.event, c.label, "verdict", "verdict", b.verdict,
                           c.verdict, message=f"{where}: the recommended model's verdict "
                                              f"got worse: {b.verdict} -> {c.verdict}"))
    elif c.verdict != b.verdict and _rank(c.verdict) > _rank(b.verdict):
        out.append(Finding(name, c.event, c.label, "new", "verdict", b.verdict, c.verdict,
                           message=f"{where} (verdict {b.verdict} -> {c.verdict})"))
    if (b.event, b.label) == (c.event, c.label):
        return out
    dist = step_response_distance(b.structure, b.params or {}, c.structure, c.params or {})
    k_change = relative_change("K", b.structure, b.params or {}, (c.params or {}).get(
        "K", math.nan)) if b.params and "K" in b.params else math.nan
    k_ok = abs(k_change) <= tol.for_param("K") or _within_ci("K", b, c)
    if math.isfinite(dist) and dist <= tol.dynamics and k_ok:
        out.append(Finding(name, c.event, c.label, "new", "recommended", b.label, c.label,
                           message=f"{where} (recommended instead of {b.label}, event "
                                   f"{b.event}: an equivalent model, step responses within "
                                   f"{pct_text(dist, sign=False)} of the gain)"))
        return out
    out.append(Finding(
        name, c.event, c.label, "recommended", "recommended", b.label, c.label, dist,
        tol.dynamics, message=f"{where}: recommended instead of {b.label} (event {b.event}), "
                              f"a different model: step responses differ by up to "
                              f"{pct_text(dist, sign=False)} of the gain (tolerance "
                              f"{pct_text(tol.dynamics, sign=False)})"))
    return out


def _rank(verdict: str | None) -> int:
    return {"ok": 0, "warning": 1, "unreliable": 2}.get(str(verdict), 0)


def _within_ci(name: str, b, c) -> bool:
    hb, hc = _half((b.ci95 or {}).get(name)), _half((c.ci95 or {}).get(name))
    bv, cv = (b.params or {}).get(name), (c.params or {}).get(name)
    if hb is None or hc is None or bv is None or cv is None:
        return False
    return abs(float(cv) - float(bv)) <= math.hypot(hb, hc)


def _compare_record(name: str, cur: RecordDoc | None, base: RecordDoc, tol: Tolerances
                    ) -> list[Finding]:
    b_status = base.status
    if cur is None:
        return [Finding(name, None, None, "missing", "status", b_status, None,
                        message=f"{name}: in the baseline ({b_status}) but not in this run")]
    c_status = cur.status
    if b_status == "ok" and c_status != "ok":
        return [Finding(name, None, None, "status", "status", "ok", c_status,
                        message=f"{name}: record was ok, now {c_status}: "
                                f"{cur.error or 'no reason given'}")]
    if b_status != "ok" and c_status == "ok":
        return [_new_item(name, None, None, f"record now ok (was {b_status})")]
    if c_status != "ok":
        return []
    fits = _compare_fits(name, cur, base, tol)
    key = recommended_fit(cur, base)
    drifted = any(f.kind == "param_drift" and (f.event, f.method) == key for f in fits)
    return [*fits, *tuning_findings(name, cur, base, key, tol, drifted),
            *loop_findings(name, cur, base, tol)]


def _fits(record: RecordDoc) -> dict[tuple[int, str], FitDoc]:
    return {(f.event, f.label): f for f in record.fits}


def _compare_fits(name: str, cur: RecordDoc, base: RecordDoc, tol: Tolerances
                  ) -> list[Finding]:
    cf, bf = _fits(cur), _fits(base)
    dy = step_size(base)
    out: list[Finding] = []
    for key, b in sorted(bf.items()):
        event, method = key
        c = cf.get(key)
        where = f"{name} event {event} {method}"
        if c is None:
            out.append(Finding(name, event, method, "missing", "status", b.status, None,
                               message=f"{where}: in the baseline ({b.status}) but not "
                                       "in this run"))
        elif b.status == "ok" and c.status != "ok":
            out.append(Finding(name, event, method, "status", "status", "ok", c.status,
                               message=f"{where}: was ok, now {c.status}: "
                                       f"{c.reason or 'no reason given'}"))
        elif b.status != "ok" and c.status == "ok":
            out.append(_new_item(name, event, method, f"now ok (was {b.status})"))
        elif b.status == "ok":
            out.extend(param_findings(name, event, method, b, c, tol))
            out.extend(mse_findings(name, event, method, b, c, tol, dy))
    out.extend(_new_item(name, e, m, "fit not in the baseline")
               for (e, m) in sorted(cf) if (e, m) not in bf)
    return out


def _new_item(record: str, event: int | None, method: str | None, what: str) -> Finding:
    where = record if method is None else f"{record} event {event} {method}"
    return Finding(record, event, method, "new", message=f"{where} ({what})")


# -- parameters --------------------------------------------------------------------------

def time_scale(structure: str | None, params: Mapping[str, float]) -> float:
    """The model's time scale (the structure table's sum of time constants), seconds;
    NaN when the structure or its parameters do not say."""
    try:
        return float(STRUCTURES[str(structure)].time_scale(
            {k: float(v) for k, v in params.items()}))
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        return math.nan


def param_scale(name: str, structure: str | None, params: Mapping[str, float]) -> float:
    """The magnitude a change of parameter ``name`` is measured against (module docstring)."""
    value = abs(float(params.get(name, 0.0)))
    spec = PARAMETERS.get(name)
    if spec is None:
        return value
    if spec.scale == "time_scale":
        ts = time_scale(structure, params)
        value = max(value, ts) if math.isfinite(ts) else value
    elif spec.scale == "dominant_lag":
        value = max(abs(float(params.get(p, 0.0))) for p in PARAMETERS
                    if PARAMETERS[p].scale == "dominant_lag")
    return max(value, spec.floor)


def relative_change(name: str, structure: str | None, base_params: Mapping[str, float],
                    current: float) -> float:
    """``(current - baseline) / scale``; 0 when both are 0, +-inf from a zero scale."""
    b = float(base_params.get(name, 0.0))
    diff = float(current) - b
    if diff == 0:
        return 0.0
    scale = param_scale(name, structure, base_params)
    return diff / scale if scale > 0 else math.copysign(math.inf, diff)


def param_findings(record: str, event: int, method: str, base: FitDoc, cur: FitDoc,
                   tol: Tolerances) -> list[Finding]:
    """Parameter drift (or a structure change) of one fit that is ok in both runs."""
    bs, cs = base.structure, cur.structure
    bp, cp = dict(base.params or {}), dict(cur.params or {})
    where = f"{record} event {event} {method}"
    out = []
    names = set(bp) | set(cp)
    if bs != cs or set(bp) - {"delay"} != set(cp) - {"delay"}:
        # another structure: only the gain and the dead time keep their meaning
        out.extend(_structure_findings(record, event, method, base, cur, tol))
        names = {"K", "delay"} & names
    # the same response from other parameters: an over-parameterised fit's dynamics are
    # not determined one by one, so only the gain and dead time are compared one by one
    same_response = bs == cs and step_response_distance(bs, bp, cs, cp) <= tol.dynamics
    for name in sorted(names, key=_param_order):
        default = 0.0 if name == "delay" else None  # no delay entry: no dead time
        b, c = bp.get(name, default), cp.get(name, default)
        if not (is_number(b) and is_number(c)):
            continue
        if same_response and name not in ("K", "delay"):
            continue
        b, c = float(b), float(c)
        change = relative_change(name, bs, bp, c)
        limit = tol.for_param(name)
        if abs(change) > limit and not within_intervals(name, b, c, base, cur):
            out.append(Finding(
                record, event, method, "param_drift", name, b, c, change, limit,
                message=f"{where}: {name} drifted {pct_text(change)} ({num_text(b)} -> "
                        f"{num_text(c)}; tolerance {pct_text(limit, sign=False)}"
                        f"{_scale_note(name, bs, bp)})"))
    return out


def within_intervals(name: str, b: float, c: float, base: FitDoc, cur: FitDoc) -> bool:
    """True when both fits carry 95 % intervals for ``name`` and the change is within
    their combined half-widths (sqrt(h_b^2 + h_c^2)): two refinements of the same plant on
    fresh noise differ by that much about one time in twenty, and no drift is shown."""
    hb, hc = _half(base.ci95.get(name)), _half(cur.ci95.get(name))
    if hb is None or hc is None:
        return False
    return abs(c - b) <= math.hypot(hb, hc)


def _half(ci) -> float | None:
    if not ci or ci[0] is None or ci[1] is None:
        return None
    return (float(ci[1]) - float(ci[0])) / 2.0


def _structure_findings(record, event, method, base: FitDoc, cur: FitDoc,
                        tol: Tolerances) -> list[Finding]:
    bs, cs = base.structure, cur.structure
    dist = step_response_distance(bs, base.params or {}, cs, cur.params or {})
    if math.isfinite(dist) and dist <= tol.dynamics:
        return []
    return [Finding(
        record, event, method, "param_drift", "structure", str(bs), str(cs), dist,
        tol.dynamics,
        message=f"{record} event {event} {method}: model structure changed {bs} -> {cs}; "
                f"step responses differ by up to {pct_text(dist, sign=False)} of the gain "
                f"(tolerance {pct_text(tol.dynamics, sign=False)})")]


def step_response_distance(structure_a: str | None, params_a: Mapping[str, float],
                           structure_b: str | None, params_b: Mapping[str, float],
                           n_points: int = 2001) -> float:
    """``max_t |S_b(t) - S_a(t)| / |K_a|`` over the unit-step responses (inf if unknown).

    The horizon is ten time scales plus the longer dead time, so both have settled. Two
    integrating models are compared relative to the rise of ramp ``a`` over the horizon,
    ``|S_a(t_end)|``; an integrating and a self-regulating one are infinitely far apart.
    """
    try:
        a = ProcessModel(str(structure_a), {k: float(v) for k, v in params_a.items()})
        b = ProcessModel(str(structure_b), {k: float(v) for k, v in params_b.items()})
    except (ValueError, TypeError):
        return math.inf
    ts = max(time_scale(a.structure, a.params), time_scale(b.structure, b.params))
    if not math.isfinite(ts) or ts <= 0 or a.K == 0 or a.integrating != b.integrating:
        return math.inf
    t = np.linspace(0.0, 10.0 * ts + max(a.delay, b.delay), n_points)
    sa = a.unit_step(t)
    scale = abs(sa[-1]) if a.integrating else abs(a.K)
    return float(np.max(np.abs(b.unit_step(t) - sa)) / scale)


# -- validation MSE ----------------------------------------------------------------------

def step_size(record: RecordDoc) -> float:
    """Median ``|y_ss - y0|`` over the record's step events (0 when there are none)."""
    dys = [abs(e.y_ss - e.y0) for e in record.events
           if e.kind == "step" and e.y_ss is not None and e.y0 is not None]
    return float(np.median(dys)) if dys else 0.0


def mse_limit(baseline_mse: float, tol: Tolerances, dy: float) -> float:
    """The largest current validation MSE that is not a regression."""
    return (1.0 + tol.mse_tol) * baseline_mse + (tol.param_tol * dy) ** 2


def mse_findings(record: str, event: int, method: str, base: FitDoc, cur: FitDoc,
                 tol: Tolerances, dy: float) -> list[Finding]:
    """Validation MSE growth of one fit that is ok in both runs (null: not compared)."""
    b, c = base.metrics.mse_validation, cur.metrics.mse_validation
    if not (is_number(b) and is_number(c)):
        return []
    b, c = float(b), float(c)
    limit = mse_limit(b, tol, dy)
    if c <= limit:
        return []
    change = (c - b) / b if b > 0 else math.inf
    return [Finding(
        record, event, method, "mse_growth", "mse_validation", b, c, change, tol.mse_tol,
        message=f"{record} event {event} {method}: validation MSE grew {pct_text(change)} "
                f"({num_text(b)} -> {num_text(c)}; limit {num_text(limit)} = (1 + "
                f"{pct_text(tol.mse_tol, sign=False)}) baseline + ({tol.param_tol:g} * step "
                f"{num_text(dy)})^2)")]


# -- formatting helpers ------------------------------------------------------------------

def _param_order(name: str) -> tuple[int, str]:
    order = list(PARAMETERS)
    return (order.index(name) if name in order else len(order), name)


def _scale_note(name: str, structure: str | None, params: Mapping[str, float]) -> str:
    if name in PARAMETERS:
        scale = param_scale(name, structure, params)
        if scale != abs(float(params.get(name, 0.0))):
            return f", relative to {num_text(scale)}"
    return ""
