"""A record's tuning as results.json carries it (:class:`pipeline.schema.TuningDoc`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..schema import (
    AlternativeDoc,
    ControllerDoc,
    LoopDoc,
    MarginsDoc,
    PlantThroughLoopDoc,
    ReducedDoc,
    ReplacedDoc,
    RunningLoopDoc,
    SetpointStepDoc,
    StepMetricsDoc,
    TuningDoc,
    WorstCaseDoc,
)
from .log_loop import LoopReading
from .loop import LoopResponse, StepMetrics
from .margins import Margins
from .tuner import Tuning


@dataclass(frozen=True)
class RecordTuning:
    """The controller tuned for a record: which fit it came from, the rule, and the
    :class:`~pipeline.tuning.Tuning` (None with the ``reason`` when the rule does not
    apply); ``units`` are the record's (input, output, time); ``r_step``/``d_step``/
    ``u_limits`` the simulated steps and actuator range (deviations)."""

    method: str
    event: int
    rule: str
    events: tuple[int, ...] = ()
    tuning: Tuning | None = None
    reason: str | None = None
    units: dict[str, str] = field(default_factory=dict)
    r_step: float = 1.0
    d_step: float | None = None
    u_limits: tuple[float, float] | None = None

    @property
    def ok(self) -> bool:
        return self.tuning is not None

    @property
    def gain_unit(self) -> str:
        """The controller gain's unit: input unit per output unit."""
        return controller_gain_unit(self.units)


def controller_gain_unit(units: dict[str, str]) -> str:
    """A controller gain's unit for a record's ``units``: input unit per output unit."""
    u, y = units.get("input", ""), units.get("output", "")
    return f"{u}/{y}" if u or y else ""


#: Flags under which a model's tuning is never called robust (the model may not be the
#: open-loop plant).
#: a loop read as a plant, or a lightly damped mode the model misses: the robust check
#: over the model's intervals says nothing of the true loop
UNTRUSTED_FLAGS = ("closed_loop_suspected", "oscillation_unmodelled")


def model_trust(verdict: str, flag_codes, warned_codes) -> tuple[bool, str]:
    """Whether a tuning from a model with this ``verdict`` and these flags may be called
    robust, and what the verdict's reasons say: never for an unreliable model or one
    flagged :data:`UNTRUSTED_FLAGS`; with a caveat for one whose flags ``warned_codes``
    are warnings ("robust only as far as the model holds")."""
    codes = set(flag_codes)
    untrusted = [c for c in UNTRUSTED_FLAGS if c in codes]
    if verdict == "unreliable":
        return False, "the model's verdict is unreliable"
    if untrusted:
        return False, f"the model is flagged {untrusted[0]}"
    warned = list(dict.fromkeys(warned_codes))
    if warned:
        return True, (f"the model itself has warnings ({', '.join(warned)}): robust only as "
                      "far as the model holds")
    return True, ""


def through_loop_trust(record_flag_codes) -> tuple[bool, str]:
    """:func:`model_trust` of the plant fitted through a closed loop (the indirect
    approach): the record's flags count, but ``closed_loop_suspected``, which says the
    direct fit is from a loop: the fit through the loop is its remedy."""
    return model_trust("ok", (c for c in record_flag_codes if c != "closed_loop_suspected"),
                       ())


def _num(v: float) -> float | None:
    return float(v) if v is not None and math.isfinite(v) else None


def margins_doc(m: Margins) -> MarginsDoc:
    return MarginsDoc(stable=bool(m.stable), ms=_num(m.ms), mt=_num(m.mt),
                      gain_margin=_num(m.gain_margin), phase_margin=_num(m.phase_margin),
                      delay_margin=_num(m.delay_margin), wc=_num(m.wc), w180=_num(m.w180))


def _metrics_doc(m: StepMetrics) -> StepMetricsDoc:
    return StepMetricsDoc(iae=float(m.iae), overshoot=float(m.overshoot),
                          peak_deviation=float(m.peak_deviation),
                          settling_time=_num(m.settling_time), u_peak=float(m.u_peak),
                          saturated=bool(m.saturated))


def _loop_doc(r: LoopResponse | None, rt: RecordTuning) -> LoopDoc | None:
    if r is None:
        return None
    d = float(r.d[-1]) if len(r.d) else 0.0
    return LoopDoc(r_step=float(r.r[-1]) if len(r.r) else rt.r_step, d_step=d,
                   u_limits=rt.u_limits, setpoint=_metrics_doc(r.setpoint),
                   load=_metrics_doc(r.load))


def _controller_doc(c) -> ControllerDoc:
    return ControllerDoc(kind=c.kind, Kc=c.Kc, Ti=_num(c.Ti), Td=c.Td, Tf=c.Tf)


def _alternative_doc(t: Tuning) -> AlternativeDoc | None:
    a = t.alternative
    if a is None or a.tau_c is None or t.alternative_ms is None:
        return None
    return AlternativeDoc(tau_c=float(a.tau_c), controller=_controller_doc(a.controller),
                          worst_ms=float(t.alternative_ms))


def _replaced_doc(t: Tuning) -> ReplacedDoc | None:
    r = t.replaced
    if r is None or r.settings.tau_c is None:
        return None
    return ReplacedDoc(tau_c=float(r.settings.tau_c),
                       controller=_controller_doc(r.settings.controller), verdict=r.verdict,
                       reasons=list(r.reasons), worst_ms=_num(r.worst_ms),
                       controller_ci95={k: (float(lo), float(hi))
                                        for k, (lo, hi) in r.spread.items()})


def tuning_doc(rt: RecordTuning | None) -> TuningDoc | None:
    """The results.json form of a record's tuning."""
    if rt is None:
        return None
    base = {"method": rt.method, "event": rt.event, "events": list(rt.events),
            "rule": rt.rule}
    t = rt.tuning
    if t is None:
        return TuningDoc(status="not_applicable", reason=rt.reason, **base)
    c, st = t.controller, t.settings
    red = st.reduced
    w = t.worst
    return TuningDoc(
        status="ok", **base, kind=c.kind, tau_c=_num(st.tau_c) if st.tau_c else None,
        ms_target=t.options.ms_target,
        reduced=ReducedDoc(kind=red.kind, K=red.K, theta=red.theta, tau1=red.tau1,
                           tau2=red.tau2, zeta=red.zeta, steps=list(red.steps)),
        controller=_controller_doc(c),
        controller_ci95={k: (float(lo), float(hi)) for k, (lo, hi) in t.spread.items()},
        form=t.options.form, time_unit=t.options.time_unit,
        settings={k: _num(v) for k, v in (t.form() or {}).items()},
        action=t.action, gain_unit=rt.gain_unit, percent_gain=t.percent_gain,
        margins=margins_doc(t.margins),
        worst_case=WorstCaseDoc(ms=_num(w.ms), stable_fraction=w.stable_fraction,
                                n_sets=w.n_sets, params=dict(w.params),
                                n_corners=w.n_corners, unstable_corners=w.unstable_corners,
                                unstable_draws=w.unstable_draws) if w else None,
        verdict=t.verdict, reasons=list(t.reasons), notes=list(t.notes),
        alternative=_alternative_doc(t), replaced=_replaced_doc(t),
        response=_loop_doc(t.response, rt), worst_response=_loop_doc(t.worst_response, rt))


def running_loop_doc(reading: LoopReading | None) -> RunningLoopDoc | None:
    """results.json's ``running_loop`` of a closed-loop log read with its setpoint."""
    if reading is None:
        return None
    run = reading.running
    steps = [SetpointStepDoc(
        time=st.time, change=st.change,
        overshoot=None if st.test is None else _num(st.test.overshoot),
        peak_time=None if st.test is None else _num(st.test.tp),
        offset_ratio=None if st.test is None else _num(st.test.offset_ratio),
        controller=None if st.controller is None else _controller_doc(st.controller),
        reason=st.reason) for st in reading.steps]
    pl = reading.plant
    plant = None if pl is None else PlantThroughLoopDoc(
        structure=pl.model.structure, params={k: float(v) for k, v in pl.model.params.items()},
        ci95={k: (_num(lo), _num(hi)) for k, (lo, hi) in pl.ci95.items()},
        std={k: float(v) for k, v in pl.std.items() if math.isfinite(v)}, rms=_num(pl.rms),
        variance_factor=_num(pl.variance_factor))
    if run is None:
        return RunningLoopDoc(setpoint=reading.setpoint, reason=reading.reason,
                              setpoint_steps=steps, plant=plant,
                              plant_reason=reading.plant_reason)
    return RunningLoopDoc(
        setpoint=reading.setpoint, controller=_controller_doc(run.controller),
        std={k: v for k, v in run.std.items() if math.isfinite(v)}, bias=_num(run.bias),
        residual_share=_num(run.residual_share), converged=run.converged,
        setpoint_steps=steps, plant=plant, plant_reason=reading.plant_reason)
