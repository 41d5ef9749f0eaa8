"""Tuning rules: P, PI and PID settings from a process model.

Each rule reads the model reduced by :func:`pipeline.tuning.reduction.reduce` (Skogestad's
half rule) and returns :class:`RuleSettings`: the controller in the ideal form
(:class:`~pipeline.tuning.controller.Controller`), the reduced model it read, the
closed-loop time constant (or lambda) it used, and notes.

- ``simc``: Skogestad, "Simple analytic rules for model reduction and PID controller
  tuning", *J. Process Control* 13 (2003) 291-309, Table 1 / Section 4. First order
  ``k e^(-theta s)/(tau1 s + 1)``: ``Kc = tau1/(k (tau_c + theta))``, ``Ti = min(tau1,
  4 (tau_c + theta))``; second order adds ``Td = tau2`` (series form); integrating
  ``k' e^(-theta s)/s``: ``Kc = 1/(k' (tau_c + theta))``, ``Ti = 4 (tau_c + theta)``, with a
  lag ``tau2``: ``Td = tau2`` (series); oscillating ``k/(tau0^2 s^2 + 2 zeta tau0 s + 1)``
  (``zeta < 1``): ``Kc = 2 zeta tau0/(k (tau_c + theta))``, ``Ti = 2 zeta tau0``, ``Td =
  tau0/(2 zeta)`` (ideal form). ``tau_c = theta`` ("tight") by default.
- ``simc_improved``: Grimholt & Skogestad, "Optimal PI and PID control of first-order plus
  delay processes and evaluation of the original and improved SIMC rules", *J. Process
  Control* 70 (2018) 36-46: PID by adding ``Td = theta/3`` to SIMC's series-form PI; PI
  with ``tau1 + theta/3`` in place of ``tau1`` (their PID'12 paper, "Optimal PI-control
  and verification of the SIMC tuning rule").
- ``lambda``: IMC / lambda tuning (Rivera, Morari & Skogestad, "Internal model control. 4.
  PID controller design", *Ind. Eng. Chem. Process Des. Dev.* 25 (1986) 252-265, Table 1):
  PI ``Kc = tau1/(k (lambda + theta))``, ``Ti = tau1``; PID with a first-order Padé
  approximation of the delay: ``Kc = (2 tau1 + theta)/(k (2 lambda + theta))``, ``Ti = tau1
  + theta/2``, ``Td = tau1 theta/(2 tau1 + theta)``; integrating (Chien & Fruehauf,
  "Consider IMC tuning to improve controller performance", *Chem. Eng. Prog.* 86 (1990)
  33-41): ``Kc = (2 lambda + theta)/(k' (lambda + theta)^2)``, ``Ti = 2 lambda + theta``.
  ``lambda = max(tau1, theta)`` by default (a closed loop as fast as the open loop), ``3
  theta`` for an integrating process.
- ``amigo``: Åström & Hägglund, "Revisiting the Ziegler-Nichols step response method for
  PID control", *J. Process Control* 14 (2004) 635-650, eqs. (7) and (10) (and *Advanced
  PID Control*, ISA 2006, Section 7.6): PI ``Kc = 0.15/K + (0.35 - L T/(L + T)^2) T/(K L)``,
  ``Ti = 0.35 L + 13 L T^2/(T^2 + 12 L T + 7 L^2)``; PID ``Kc = (0.2 + 0.45 T/L)/K``, ``Ti =
  L (0.4 L + 0.8 T)/(L + 0.1 T)``, ``Td = 0.5 L T/(0.3 L + T)``; integrating ``Kv e^(-L
  s)/s``: PI ``Kc = 0.35/(Kv L)``, ``Ti = 13.4 L``; PID ``Kc = 0.45/(Kv L)``, ``Ti = 8 L``,
  ``Td = 0.5 L``.

P control is the PI rule's gain without the integral (SIMC's P rule for an integrating
process, Skogestad 2003 Section 4; the same gain for a self-regulating one).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

from ..models import ProcessModel
from .controller import Controller, ControllerKind
from .reduction import Reduced, reduce

RuleName = Literal["simc", "simc_improved", "lambda", "amigo"]
KindChoice = Literal["auto", "P", "PI", "PID"]

#: ``tau_c`` by name: "tight" is SIMC's ``tau_c = theta``; "smooth" is three times slower
#: (``tau_c = 3 theta``, Ms about 1.3 on a lag-dominant process): the slower end of the
#: range Skogestad 2003 recommends (``tau_c >= theta``) that we offer by name.
TAU_C_FACTORS = {"tight": 1.0, "smooth": 3.0}

#: Without any dead time (no delay, no sample period) ``tau_c = theta`` would ask for an
#: infinite gain: ``tau_c`` is then this fraction of the process's largest lag.
NO_DELAY_FRACTION = 0.1


@dataclass(frozen=True)
class RuleSettings:
    """A rule's answer: ``controller`` (ideal form), the ``reduced`` model it read,
    ``tau_c`` (the closed-loop time constant or lambda; None for AMIGO), the form the
    rule states its settings in, and ``notes``."""

    rule: RuleName
    controller: Controller
    reduced: Reduced
    tau_c: float | None
    rule_form: Literal["ideal", "series"]
    notes: tuple[str, ...] = field(default_factory=tuple)


def _tau_c(red: Reduced, tau_c: float | str | None, default: float) -> tuple[float, list[str]]:
    notes: list[str] = []
    if isinstance(tau_c, int | float) and not isinstance(tau_c, bool):
        if tau_c <= 0:
            raise ValueError(f"tau_c must be positive, not {tau_c}")
        return float(tau_c), notes
    factor = TAU_C_FACTORS.get(tau_c or "tight")
    if factor is None:
        raise ValueError(f"tau_c must be a number of seconds or one of "
                         f"{', '.join(TAU_C_FACTORS)}, not {tau_c!r}")
    value = factor * default
    if value <= 0:
        scale = red.tau1 if red.tau1 > 0 else 1.0
        value = factor * NO_DELAY_FRACTION * scale
        notes.append(f"the model has no dead time: tau_c = {value:.4g} s "
                     f"({factor * NO_DELAY_FRACTION:g} x its lag); give tau_c to choose")
    return value, notes


def _auto_kind(rule: RuleName, model: ProcessModel, sample_time: float) -> ControllerKind:
    if rule in ("lambda", "amigo"):
        return "PI"
    if rule == "simc_improved":
        return "PID"
    red2 = reduce(model, 2, sample_time)
    if red2.kind == "oscillating":
        return "PID"
    if red2.kind in ("second_order", "integrator_lag") and red2.tau2 + (
            red2.tau1 if red2.kind == "integrator_lag" else 0.0) >= red2.theta:
        return "PID"
    return "PI"


#: Fixed-point passes for SIMC's derivative filter counted as dead time (the filter time
#: moves the dead time, which moves Ti and so the filter: a contraction by about 1/N).
FILTER_PASSES = 6


def _simc(model: ProcessModel, kind: ControllerKind, tau_c, h: float,
          improved: bool = False) -> RuleSettings:
    """SIMC's settings (module docstring). With derivative action the filter ``Tf`` is a
    lag the loop sees, and SIMC counts it, like every small lag, in the effective dead
    time (the half rule, Skogestad 2003 Section 3.1): the settings read ``theta + Tf``
    (and "tight" ``tau_c = theta + Tf``); improved SIMC stays as published. Without it
    ``Tf = Td/10`` costs SIMC's robustness on lag-dominant processes: on
    ``e^(-s)/(5s+1)^2`` Ms 1.87 instead of the rule's 1.59 unfiltered; counted, 1.62
    (tests/test_tuning_rules.py)."""
    notes: list[str] = []
    red = reduce(model, 2 if kind == "PID" and not improved else 1, h)
    if kind == "PID" and red.kind == "first_order" and not improved:
        notes.append("the model reduces to first order: SIMC gives no derivative action "
                     "(simc_improved adds Td = theta/3)")
    tf = 0.0
    # improved SIMC is kept as published: its filter (Td/10 = theta/30) is negligible
    for _ in range(1 if improved else FILTER_PASSES):
        controller, form, tc, more = _simc_settings(red, kind, tau_c, red.theta + tf,
                                                    improved)
        if abs(controller.Tf - tf) <= 1e-9 * max(red.theta + tf, 1e-300):
            break
        tf = controller.Tf
    if controller.Tf > 0 and not improved:
        more.append(f"the derivative filter (Tf = {controller.Tf:.3g} s) is counted in "
                    f"the dead time: theta {red.theta + controller.Tf:.3g} s")
    rule: RuleName = "simc_improved" if improved else "simc"
    return RuleSettings(rule, controller, red, tc, form, tuple(notes + more))


def _simc_settings(red: Reduced, kind: ControllerKind, tau_c, theta: float,
                   improved: bool) -> tuple[Controller, Literal["ideal", "series"], float,
                                            list[str]]:
    """SIMC's controller on the reduced model ``red`` with the effective dead time
    ``theta`` (the model's, plus the derivative filter's), its form, ``tau_c``, notes."""
    tc, notes = _tau_c(red, tau_c, theta)
    k = red.K
    if red.integrating:
        kc = 1.0 / (k * (tc + theta))
        ti = 4.0 * (tc + theta) if kind != "P" else math.inf
        td = red.tau1 if kind == "PID" and red.kind == "integrator_lag" else 0.0
        if kind == "PID" and improved:
            td = red.theta / 3.0
        return Controller.series(kc, ti, td), "series", tc, notes
    if red.kind == "oscillating":
        tau0, zeta = red.tau1, red.zeta
        kc = 2.0 * zeta * tau0 / (k * (tc + theta))
        ti = 2.0 * zeta * tau0 if kind != "P" else math.inf
        td = tau0 / (2.0 * zeta) if kind == "PID" else 0.0
        return Controller.ideal(kc, ti, td), "ideal", tc, notes
    # improved SIMC: PI reads tau1 + theta/3 (Grimholt & Skogestad 2012); PID keeps
    # tau1 and adds Td = theta/3 to the series form (Grimholt & Skogestad 2018)
    tau1 = red.tau1 + (red.theta / 3.0 if improved and kind != "PID" else 0.0)
    # a pure dead time (tau1 = 0) is the limit of an integral controller: keep the ratio
    tau1 = max(tau1, 1e-9 * max(theta, 1e-300))
    kc = tau1 / (k * (tc + theta))
    ti = min(tau1, 4.0 * (tc + theta)) if kind != "P" else math.inf
    if kind != "PID":
        td = 0.0
    elif improved:
        td = red.theta / 3.0
    else:
        td = red.tau2
    return Controller.series(kc, ti, td), "series", tc, notes


def _lambda(model: ProcessModel, kind: ControllerKind, tau_c, h: float) -> RuleSettings:
    red = reduce(model, 1, h)
    k, theta = red.K, red.theta
    notes: list[str] = []
    if red.integrating:
        lam, notes = _tau_c(red, tau_c, 3.0 * theta)
        kc = (2.0 * lam + theta) / (k * (lam + theta) ** 2)
        ti = 2.0 * lam + theta if kind != "P" else math.inf
        if kind == "PID":
            notes.append("lambda tuning of an integrating process gives PI")
        return RuleSettings("lambda", Controller.ideal(kc, ti), red, lam, "ideal",
                            tuple(notes))
    lam, notes = _tau_c(red, tau_c, max(red.tau1, theta))
    tau1 = red.tau1
    if kind == "PID" and tau1 > 0:
        kc = (2.0 * tau1 + theta) / (k * (2.0 * lam + theta))
        return RuleSettings("lambda", Controller.ideal(
            kc, tau1 + theta / 2.0, tau1 * theta / (2.0 * tau1 + theta)), red, lam, "ideal",
            tuple(notes))
    tau1 = max(tau1, 1e-9 * max(theta, 1e-300))
    kc = tau1 / (k * (lam + theta))
    return RuleSettings("lambda", Controller.ideal(kc, tau1 if kind != "P" else math.inf),
                        red, lam, "ideal", tuple(notes))


def _amigo(model: ProcessModel, kind: ControllerKind, tau_c, h: float) -> RuleSettings:
    if tau_c is not None:
        raise ValueError("AMIGO has no tau_c: its robustness is fixed (Ms about 1.4)")
    if kind == "P":
        raise ValueError("AMIGO gives PI and PID settings, not P")
    red = reduce(model, 1, h)
    k, L, T = red.K, red.theta, red.tau1
    if L <= 0:
        raise ValueError("AMIGO needs a dead time (the model has none)")
    if red.integrating:
        c = (Controller.ideal(0.35 / (k * L), 13.4 * L) if kind == "PI"
             else Controller.ideal(0.45 / (k * L), 8.0 * L, 0.5 * L))
        return RuleSettings("amigo", c, red, None, "ideal")
    if kind == "PI":
        kc = 0.15 / k + (0.35 - L * T / (L + T) ** 2) * T / (k * L)
        ti = 0.35 * L + 13.0 * L * T * T / (T * T + 12.0 * L * T + 7.0 * L * L)
        return RuleSettings("amigo", Controller.ideal(kc, ti), red, None, "ideal")
    kc = (0.2 + 0.45 * T / L) / k
    ti = L * (0.4 * L + 0.8 * T) / (L + 0.1 * T)
    td = 0.5 * L * T / (0.3 * L + T)
    return RuleSettings("amigo", Controller.ideal(kc, ti, td), red, None, "ideal")


_RULES: dict[str, Callable[..., RuleSettings]] = {
    "simc": _simc,
    "simc_improved": lambda m, k, t, h: _simc(m, k, t, h, improved=True),
    "lambda": _lambda,
    "amigo": _amigo,
}

#: The rule ids, in the order the report lists them.
RULE_NAMES: tuple[RuleName, ...] = ("simc", "simc_improved", "lambda", "amigo")


def tune_rule(model: ProcessModel, rule: RuleName = "simc", kind: KindChoice = "auto",
              tau_c: float | str | None = None, sample_time: float = 0.0) -> RuleSettings:
    """Controller settings for ``model`` by ``rule`` (see the module docstring).

    ``kind``: "P", "PI", "PID" or "auto" (SIMC: PID when the second-order reduction keeps
    a lag at least as long as the dead time, or the model oscillates; improved SIMC: PID;
    lambda and AMIGO: PI). ``tau_c``: seconds, "tight" (``theta``), "smooth" (``3
    theta``), or None for the rule's default. ``sample_time``: the controller's sample
    period (adds half of it to the dead time). Raises ValueError when the rule does not
    apply (the message says why)."""
    if rule not in _RULES:
        raise ValueError(f"unknown tuning rule {rule!r}; one of {', '.join(RULE_NAMES)}")
    if model.K == 0 or not math.isfinite(model.K):
        raise ValueError("the model's gain is zero or not finite: nothing to tune")
    h = float(sample_time or 0.0)
    k: ControllerKind = _auto_kind(rule, model, h) if kind == "auto" else kind
    return _RULES[rule](model, k, tau_c, h)
