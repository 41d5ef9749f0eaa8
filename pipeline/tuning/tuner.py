"""From a model to controller settings an engineer can enter: rule, margins with the
exact delay, the worst case over the model's 95 % intervals, the tuned loop simulated.

:func:`tune` is pure: a :class:`~pipeline.models.ProcessModel` (with its intervals and
covariance when it is a refinement) and :class:`TuningOptions` in, a :class:`Tuning` out.

The tuning verdict (robust / fragile / unstable_in_interval; "unchecked" when the model
has no interval to check over or its own verdict does not allow trust):

- ``unstable_in_interval``: the closed loop is unstable on the model itself or on a
  parameter set inside its 95 % intervals;
- ``fragile``: stable everywhere, but the worst-case Ms exceeds :data:`FRAGILE_MS` (2.0;
  Åström & Hägglund, *Advanced PID Control*, 2006, Section 4.3: Ms in 1.2-2.0 is the
  reasonable range, above 2 a loop is poorly damped and sensitive to model errors);
- ``robust``: stable on every set and the worst-case Ms at most 2.0.

When ``tau_c`` is not given and the rule's default settings are fragile or unstable over
the interval, the tuning gives the same rule with the fastest ``tau_c`` whose worst case
keeps Ms at :data:`FRAGILE_MS` instead (the settings an engineer can enter on a loop the
data do not pin down), and keeps the default ones in ``replaced`` with their verdict:
the end-to-end benchmark's plants identified under AR(1) noise and first-order models
with a dead time of a few milliseconds got unstable default settings, whose true loop
was poorly damped (``benchmarks/tuning_e2e.py``). ``tau_c: "tight"`` keeps the default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from ..fit import ParameterCovariance
from ..models import ProcessModel
from .controller import Controller
from .loop import LoopResponse, Pid, simulate_loop
from .margins import Margins, loop_margins
from .plant import response, rhp_poles
from .robust import N_DRAWS, WorstCase, loop_scale, n_corners, parameter_sets, worst_case
from .rules import KindChoice, RuleName, RuleSettings, tune_rule

TuningVerdict = Literal["robust", "fragile", "unstable_in_interval", "unchecked"]
TUNING_VERDICTS: tuple[TuningVerdict, ...] = ("robust", "fragile", "unstable_in_interval",
                                              "unchecked")
ControllerForm = Literal["ideal", "parallel", "series"]
TimeUnit = Literal["s", "min"]

#: Above this worst-case Ms the tuning is "fragile" (see the module docstring).
FRAGILE_MS = 2.0
#: The verdicts in a sentence ("the default settings are ...").
VERDICT_WORDS = {"unstable_in_interval": "unstable over the interval"}
#: The default Ms target when tau_c is chosen from the worst case.
MS_TARGET = 1.7


@dataclass(frozen=True)
class TuningOptions:
    """How to tune: the ``rule`` and controller ``kind``; ``tau_c`` (seconds, "tight",
    "smooth", or None: the rule's default); ``ms_target``: choose tau_c (lambda) so that
    the worst-case Ms over the interval is at most this (None: use ``tau_c``); the form
    and time unit the settings are shown in; ``input_span``/``output_span`` (the
    instrument ranges, for a gain in %/%); ``u_limits``: the actuator's limits in input
    units (None: the range the log saw); ``simulate``: the loop's responses;
    ``sample_time``: the controller's sample period (half of it is added to the dead
    time, Skogestad 2003 Section 3.3; 0: a continuous controller). With ``tau_c`` None and
    no ``ms_target``, settings that are fragile or unstable over the interval are replaced
    by the robust choice of tau_c (the module docstring)."""

    rule: RuleName = "simc"
    kind: KindChoice = "auto"
    tau_c: float | str | None = None
    ms_target: float | None = None
    form: ControllerForm = "ideal"
    time_unit: TimeUnit = "s"
    input_span: float | None = None
    output_span: float | None = None
    u_limits: tuple[float, float] | None = None
    simulate: bool = True
    sample_time: float = 0.0
    n_draws: int = N_DRAWS


@dataclass(frozen=True)
class Replaced:
    """The rule's default settings that a tuning did not give: their verdict, its
    reasons, their worst-case Ms over the interval (inf: unstable somewhere) and their
    spread over the interval's sets (:func:`settings_spread`). The regression gate
    compares these: they follow the model continuously, where the held settings also
    follow the interval's width (the wider it is, the further tau_c is held back)."""

    settings: RuleSettings
    verdict: TuningVerdict
    reasons: tuple[str, ...]
    worst_ms: float
    spread: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class Tuning:
    """A tuned controller: the rule's settings, the nominal margins, the worst case over
    the interval, the verdict and its reasons, and the loop's simulated responses
    (``response`` on the model, ``worst_response`` on the worst parameter set)."""

    model: ProcessModel
    settings: RuleSettings
    margins: Margins
    worst: WorstCase | None
    verdict: TuningVerdict
    reasons: tuple[str, ...]
    options: TuningOptions
    response: LoopResponse | None = None
    worst_response: LoopResponse | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    #: the range of the ideal-form settings the same rule gives on the interval's parameter
    #: sets (``Kc`` signed; empty without an interval): :func:`settings_spread`
    spread: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: when settings asked for by ``tau_c`` are fragile or unstable over the interval:
    #: the same rule with the fastest tau_c whose worst case keeps Ms at
    #: :data:`MS_TARGET` (None otherwise, for AMIGO, or when no tau_c reaches it)
    alternative: RuleSettings | None = None
    alternative_ms: float | None = None
    #: the rule's default settings when they were fragile or unstable over the interval
    #: and ``settings`` are the robust choice instead (``tau_c`` not given)
    replaced: Replaced | None = None

    @property
    def controller(self) -> Controller:
        return self.settings.controller

    @property
    def action(self) -> Literal["reverse", "direct"]:
        """ISA's controller action: "reverse" (the output falls as the measurement rises)
        for a process whose gain is positive, "direct" for a negative one."""
        return "reverse" if self.model.K > 0 else "direct"

    def form(self, form: ControllerForm | None = None, time_unit: TimeUnit | None = None
             ) -> dict[str, float] | None:
        """The settings in ``form`` (default: the options'), times in ``time_unit``; the
        gain magnitudes (the action carries the sign). None: no series equivalent."""
        form = form or self.options.form
        per = 60.0 if (time_unit or self.options.time_unit) == "min" else 1.0
        c = self.controller
        if form == "parallel":
            p = c.parallel()
            return {"Kp": abs(p["Kp"]), "Ki": abs(p["Ki"]) * per, "Kd": abs(p["Kd"]) / per}
        if form == "series":
            srs = c.as_series()
            if srs is None:
                return None
            return {"Kc": abs(srs["Kc"]), "Ti": srs["Ti"] / per, "Td": srs["Td"] / per}
        return {"Kc": abs(c.Kc), "Ti": c.Ti / per, "Td": c.Td / per, "Tf": c.Tf / per}

    @property
    def percent_gain(self) -> float | None:
        """The gain in %/% (output span over input span), when both spans are known."""
        o = self.options
        if not o.input_span or not o.output_span:
            return None
        return abs(self.controller.Kc) * o.output_span / o.input_span


def nominal_margins(model: ProcessModel, controller: Controller) -> Margins:
    """Ms, GM, PM, delay margin and stability of ``controller`` on ``model``."""
    c = controller
    return loop_margins(lambda s: c.response(s) * response(model, s), delay=model.delay,
                        time_scale=loop_scale(_ts(model), model.delay, c),
                        origin_poles=int(c.integrating) + int(model.integrating),
                        rhp_poles=rhp_poles(model))


def _ts(model: ProcessModel) -> float:
    ts = model.time_scale
    return ts if math.isfinite(ts) else 0.0


def _verdict(margins: Margins, worst: WorstCase | None, trusted: bool, why_not: str
             ) -> tuple[TuningVerdict, list[str]]:
    if not margins.stable:
        return "unstable_in_interval", ["the loop is unstable on the model itself"]
    if worst is not None and not worst.stable:
        share = 100.0 * (1.0 - worst.stable_fraction)
        where = []
        if worst.n_corners:
            where.append(f"{worst.unstable_corners} of the {worst.n_corners} corners of the "
                         "95 % box (every parameter at an end of its interval at once)")
        draws = worst.n_sets - 1 - worst.n_corners
        if draws:
            where.append(f"{worst.unstable_draws} of {draws} draws from the parameter "
                         "covariance")
        return "unstable_in_interval", [
            f"unstable on {share:.3g} % of {worst.n_sets} parameter sets inside the 95 % "
            "intervals" + (f": {' and '.join(where)}" if where else "")]
    ms = worst.ms if worst is not None else margins.ms
    where = "over the 95 % intervals" if worst is not None else "on the model"
    if ms > FRAGILE_MS:
        return "fragile", [f"Ms reaches {ms:.3g} {where} (above {FRAGILE_MS:g})"]
    if worst is None:
        return "unchecked", [f"Ms {margins.ms:.3g} on the model; {why_not}"]
    if not trusted:
        return "unchecked", [f"worst-case Ms {worst.ms:.3g}; {why_not}"]
    out = [f"stable on all {worst.n_sets} parameter sets, worst-case Ms {worst.ms:.3g} "
           f"(at most {FRAGILE_MS:g})"]
    if why_not:  # trusted, with a caveat (a model with warnings)
        out.append(why_not)
    return "robust", out


def _tau_c_for_target(model: ProcessModel, opt: TuningOptions, sets, h: float
                      ) -> RuleSettings:
    """The fastest tau_c (lambda) whose worst-case Ms over ``sets`` is at most the
    target: bisection on log tau_c (Ms falls as tau_c grows for these rules)."""
    if opt.rule == "amigo":
        raise ValueError("AMIGO has no tau_c to choose: use simc, simc_improved or lambda "
                         "with ms_target")
    base = tune_rule(model, opt.rule, opt.kind, None, h)
    tc0 = base.tau_c or 1.0
    target = float(opt.ms_target)

    def worst_ms(tc: float) -> tuple[float, RuleSettings]:
        st = tune_rule(model, opt.rule, opt.kind, tc, h)
        return worst_case(model, st.controller, sets).ms, st

    lo, hi = 0.05 * tc0, 20.0 * tc0
    ms_hi, st_hi = worst_ms(hi)
    while ms_hi > target and hi < 1e4 * tc0:
        lo, hi = hi, hi * 10.0
        ms_hi, st_hi = worst_ms(hi)
    if ms_hi > target:
        raise ValueError(f"no tau_c up to {hi:.4g} s keeps the worst-case Ms at or below "
                         f"{target:g}")
    ms_lo, st_lo = worst_ms(lo)
    if ms_lo <= target:
        return replace(st_lo, notes=st_lo.notes + (
            f"tau_c = {lo:.4g} s already keeps the worst-case Ms at {ms_lo:.3g}",))
    for _ in range(30):
        mid = math.sqrt(lo * hi)
        ms_mid, st_mid = worst_ms(mid)
        if ms_mid <= target:
            hi, st_hi, ms_hi = mid, st_mid, ms_mid
        else:
            lo = mid
        if hi / lo < 1.01:
            break
    return replace(st_hi, notes=st_hi.notes + (
        f"tau_c = {hi:.4g} s chosen for a worst-case Ms of {ms_hi:.3g} (target "
        f"{target:g})",))


def _simulate(model: ProcessModel, c: Controller, r_step: float, d_step: float | None,
              u_limits, like: LoopResponse | None = None
              ) -> tuple[LoopResponse | None, str | None]:
    """The loop on ``model``; ``like``: on the same time grid and load time as that
    response (the worst case beside the nominal one)."""
    nd = model.num_den()
    note = None
    if nd is None:  # a non-integer n: the nearest integer chain with the same residence
        n = max(1, round(float(model.params["n"])))
        T = float(model.params["T"]) * float(model.params["n"]) / n
        approx = ProcessModel("n_lags", {"K": model.K, "T": T, "n": float(n),
                                         "delay": model.delay})
        nd = approx.num_den()
        note = (f"the loop is simulated with n = {n} lags of {T:.4g} s (the same residence "
                f"time as n = {float(model.params['n']):.3g})")
    pid = Pid(Kc=c.Kc, Ti=c.Ti, Td=c.Td, Tf=c.Tf)
    grid = {}
    if like is not None and like.t.size > 1:
        loaded = np.flatnonzero(like.d != 0)
        grid = {"t_end": float(like.t[-1]),
                "t_load": float(like.t[loaded[0]]) if loaded.size else None}
    try:
        return simulate_loop(nd[0], nd[1], model.delay, pid, r_step=r_step, d_step=d_step,
                             u_limits=u_limits, **grid), note
    except (ValueError, ArithmeticError) as exc:
        return None, f"the loop could not be simulated: {exc}"


def tune(model: ProcessModel, options: TuningOptions | None = None, *,
         ci95: dict[str, tuple[float, float]] | None = None,
         covariance: ParameterCovariance | None = None, trusted: bool = True,
         why_not: str = "", r_step: float | None = None, d_step: float | None = None,
         u_limits: tuple[float, float] | None = None) -> Tuning:
    """Tune a controller for ``model`` (pure).

    ``ci95``/``covariance``: the model's 95 % intervals and parameter covariance (a
    refinement's); without them the settings are checked on the model alone and the
    verdict is at best "unchecked". ``trusted``: False when the model's own verdict or a
    closed-loop suspicion rules out calling the tuning robust (``why_not`` says why).
    ``r_step``/``d_step``: the setpoint and load steps simulated (output and input units;
    default 1 and the input step that moves the output by ``r_step``); ``u_limits``: the
    actuator's range as deviations from the operating point. Raises ValueError when the
    rule does not apply."""
    opt = options or TuningOptions()
    h = float(opt.sample_time or 0.0)
    sets = parameter_sets(model, ci95 or {}, covariance, opt.n_draws) if (
        ci95 or covariance is not None) else None
    if opt.ms_target is not None:
        settings = _tau_c_for_target(model, opt, sets or [_nominal(model)], h)
    else:
        settings = tune_rule(model, opt.rule, opt.kind, opt.tau_c, h)
    corners = n_corners(model, ci95 or {})
    why = why_not or ("the model has no interval to check the settings over"
                      if not sets or len(sets) < 2 else "")
    margins, worst, verdict, reasons = _evaluate(model, settings.controller, sets, corners,
                                                 trusted, why)
    # tau_c not given: the settings that hold take the default's place (a worst case at
    # the verdict's limit); given by name or in seconds: the robust choice beside them
    held = alt = alt_ms = None
    if opt.tau_c is None:
        held = _alternative(model, opt, sets, h, verdict, FRAGILE_MS)
    else:
        alt = _alternative(model, opt, sets, h, verdict, MS_TARGET)
        alt_ms = worst_case(model, alt.controller, sets).ms if alt is not None else None
    replaced = None
    if held is not None:
        # the rule's default tau_c was not asked for by name: give the settings that hold
        # over the interval, and say what the default would have been
        default_words = _verdict_words(verdict, margins)
        replaced = Replaced(settings, verdict, tuple(reasons),
                            worst.ms if worst is not None and worst.stable else math.inf,
                            settings_spread(model, settings, opt, sets or [], h))
        settings, alt, alt_ms = held, None, None
        margins, worst, verdict, reasons = _evaluate(model, settings.controller, sets,
                                                     corners, trusted, why)
        reasons.insert(0, f"the rule's default tau_c ({replaced.settings.tau_c:.4g} s: "
                       f"{_settings_text(replaced.settings.controller)}) is "
                       f"{default_words} "
                       f"({replaced.reasons[0]}); "
                       f"tau_c = {settings.tau_c:.4g} s is the fastest whose worst case "
                       f"keeps Ms at or below {FRAGILE_MS:g} (tau_c: tight keeps the "
                       f"default, tau_c: robust aims at {MS_TARGET:g})")
    elif alt is not None:
        reasons.append(f"tau_c = {alt.tau_c:.4g} s (tau_c: robust) keeps the worst-case Ms "
                       f"at {alt_ms:.3g}: {_settings_text(alt.controller)}")
    c = settings.controller
    notes = list(settings.notes)
    resp = worst_resp = None
    if opt.simulate and margins.stable:
        r = 1.0 if r_step is None else float(r_step)
        resp, note = _simulate(model, c, r, d_step, u_limits)
        if note:
            notes.append(note)
        if worst is not None and worst.stable and worst.params != _nominal(model):
            wm = ProcessModel(model.structure, worst.params)
            worst_resp, _ = _simulate(wm, c, r, d_step, u_limits, like=resp)
    return Tuning(model=model, settings=settings, margins=margins, worst=worst,
                  verdict=verdict, reasons=tuple(reasons), options=opt, response=resp,
                  worst_response=worst_resp, notes=tuple(notes),
                  spread=settings_spread(model, settings, opt, sets or [], h,
                                         chosen=replaced is not None),
                  alternative=alt, alternative_ms=alt_ms, replaced=replaced)


def _evaluate(model: ProcessModel, c: Controller, sets, corners: int, trusted: bool,
              why_not: str) -> tuple[Margins, WorstCase | None, TuningVerdict, list[str]]:
    """The settings' margins on the model, their worst case over ``sets`` and the
    verdict with its reasons."""
    margins = nominal_margins(model, c)
    worst = worst_case(model, c, sets, corners) if sets and len(sets) > 1 else None
    verdict, reasons = _verdict(margins, worst, trusted, why_not)
    return margins, worst, verdict, reasons


def _alternative(model: ProcessModel, opt: TuningOptions, sets, h: float,
                 verdict: TuningVerdict, target: float) -> RuleSettings | None:
    """The fastest tau_c whose worst case keeps Ms at ``target``, beside settings that
    are fragile or unstable over the interval, when the rule has a tau_c to choose and no
    Ms target was asked for (None otherwise). With ``target`` at :data:`FRAGILE_MS`, the
    verdict's own limit, the settings in place of the default are continuous in the data
    (a default whose worst case is just below the limit and one just above it give nearly
    the same settings: fresh noise does not make the gate's tuned Kc jump); with
    :data:`MS_TARGET`, what an engineer who asked for tau_c by name is offered beside
    it."""
    if verdict not in ("fragile", "unstable_in_interval") or not sets or len(sets) < 2 \
            or opt.ms_target is not None or opt.rule == "amigo":
        return None
    try:
        return _tau_c_for_target(model, replace(opt, ms_target=target), sets, h)
    except ValueError:
        return None


def _verdict_words(verdict: TuningVerdict, margins: Margins) -> str:
    """A verdict in a sentence: "unstable" when the loop is unstable on the model itself,
    "unstable over the interval" when only on sets inside it."""
    if not margins.stable:
        return "unstable"
    return VERDICT_WORDS.get(verdict, verdict)


def _settings_text(c: Controller) -> str:
    parts = [f"Kc {abs(c.Kc):.4g}"]
    if math.isfinite(c.Ti):
        parts.append(f"Ti {c.Ti:.4g} s")
    if c.Td > 0:
        parts.append(f"Td {c.Td:.4g} s")
    return ", ".join(parts) + " (ideal form)"


def settings_spread(model: ProcessModel, settings: RuleSettings, opt: TuningOptions,
                    sets, h: float, *, chosen: bool = False
                    ) -> dict[str, tuple[float, float]]:
    """How far the data determine the settings: the same rule (with the same controller
    kind; with ``tau_c`` fixed when it was chosen for an Ms target (``chosen``: in place of
    the rule's default) or given in seconds,
    else re-derived from each set's dead time) applied to every parameter set inside the
    model's intervals (the box corners and covariance draws the worst case is taken
    over), the smallest and largest ``Kc``, ``Ti``, ``Td``. The regression gate reads it
    as the settings' noise (two nights' settings further apart than their combined
    half-widths are not explained by the data), the report as their uncertainty."""
    if len(sets) < 3:
        return {}
    fixed = settings.tau_c if (chosen or opt.ms_target is not None or isinstance(
        opt.tau_c, int | float)) else opt.tau_c
    kind = settings.controller.kind
    rows = []
    for p in sets[1:]:
        try:
            c = tune_rule(ProcessModel(model.structure, p), opt.rule, kind, fixed,
                          h).controller
        except ValueError:
            continue
        rows.append((c.Kc, c.Ti, c.Td))
    if len(rows) < 2:
        return {}
    a = np.array(rows, dtype=np.float64)
    out = {}
    for j, name in enumerate(("Kc", "Ti", "Td")):
        col = a[:, j][np.isfinite(a[:, j])]
        if col.size >= 2 and (name != "Td" or np.any(col > 0)) and (
                name != "Ti" or math.isfinite(settings.controller.Ti)):
            out[name] = (float(np.min(col)), float(np.max(col)))
    return out


def _nominal(model: ProcessModel) -> dict[str, float]:
    p = {k: float(v) for k, v in model.params.items()}
    p.setdefault("delay", 0.0)
    return p


__all__ = ["FRAGILE_MS", "MS_TARGET", "TUNING_VERDICTS", "ControllerForm", "TimeUnit",
           "Tuning", "TuningOptions", "TuningVerdict", "nominal_margins", "tune"]
