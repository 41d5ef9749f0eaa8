"""A process model reduced to the form a tuning rule reads: Skogestad's half rule.

Every structure of :mod:`pipeline.models` becomes a first- or second-order model with an
effective dead time (or an integrating one) by the rules of Skogestad, "Simple analytic
rules for model reduction and PID controller tuning", *J. Process Control* 13 (2003)
291-309, Section 3 (seed text: the paper's abstract and Section 3 as summarised here):

- an inverse-response zero ``(-T0 s + 1)`` becomes dead time ``T0`` (eq. (8));
- a left-half-plane zero ``(T0 s + 1)`` cancels against the lag ``tau0`` nearest above it
  by rules T1-T3 (eq. (10)): ``T0/tau0`` if ``T0 >= tau0 >= theta``, ``T0/theta`` if
  ``T0 >= theta >= tau0``, ``1`` if ``theta >= T0 >= tau0``, ``T0/tau0`` if
  ``tau0 >= T0 >= 5 theta``, and ``(tau0~/tau0)/((tau0~ - T0) s + 1)`` with
  ``tau0~ = min(tau0, 5 theta)`` if ``tau0~ >= T0``;
- the half rule (eqs. (11)-(12)): the largest neglected lag is split, half to the smallest
  lag kept and half to the dead time; the smaller ones go to the dead time whole; for a
  first-order model ``tau1 = tau10 + tau20/2``, ``theta = theta0 + tau20/2 + sum_{i>=3}
  tau_i0 + h/2``, for a second-order one ``tau2 = tau20 + tau30/2``, ``theta = theta0 +
  tau30/2 + sum_{i>=4} tau_i0 + h/2``;
- a digital controller's sample period ``h`` adds ``h/2`` to the dead time (Section 3.3);
- an integrator is a lag of infinite time constant: every finite lag is "smaller";
- a lag behind a lightly damped pair (``lag_second_order``) has no rule in the paper: the
  pair is read as a lag of ``max(2 zeta, 1)/wn`` (its time scale), and its resonance is
  left to the check over the model's intervals, which reads the exact response.

``n_lags`` with a non-integer ``n`` (``n`` equal lags ``T``) is read as ``floor(n)`` lags
``T`` and one lag ``(n - floor(n)) T``, so that the reduction is continuous in ``n``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from ..models import ProcessModel

ReducedKind = Literal["first_order", "second_order", "oscillating", "integrator",
                      "integrator_lag"]


@dataclass(frozen=True)
class Reduced:
    """The model a rule reads: gain ``K`` (per second for the integrating kinds), lags
    ``tau1 >= tau2`` (0 when absent), effective dead time ``theta``; ``oscillating`` is
    ``K e^(-theta s)/(tau0^2 s^2 + 2 zeta tau0 s + 1)`` with ``zeta < 1`` (``tau1`` holds
    ``tau0``). ``steps`` say in words what the reduction did."""

    kind: ReducedKind
    K: float
    theta: float
    tau1: float = 0.0
    tau2: float = 0.0
    zeta: float = 1.0
    steps: tuple[str, ...] = field(default_factory=tuple)

    @property
    def integrating(self) -> bool:
        return self.kind in ("integrator", "integrator_lag")

    def model(self) -> ProcessModel:
        """The reduced model as a :class:`~pipeline.models.ProcessModel`."""
        if self.kind == "integrator":
            return ProcessModel("integrator", {"K": self.K, "delay": self.theta})
        if self.kind == "integrator_lag":
            return ProcessModel("integrator_lag", {"K": self.K, "T": self.tau1,
                                                   "delay": self.theta})
        if self.kind == "oscillating":
            return ProcessModel("second_order", {"K": self.K, "zeta": self.zeta,
                                                 "wn": 1.0 / self.tau1, "delay": self.theta})
        if self.kind == "second_order":
            return ProcessModel("two_lags", {"K": self.K, "T1": self.tau1, "T2": self.tau2,
                                             "delay": self.theta})
        return ProcessModel("first_order", {"K": self.K, "T": self.tau1, "delay": self.theta})


@dataclass(frozen=True)
class _Parts:
    K: float
    delay: float
    lags: tuple[float, ...]  # descending
    integrators: int = 0
    lhp_zeros: tuple[float, ...] = ()
    oscillating: tuple[float, float] | None = None  # (tau0, zeta)
    steps: tuple[str, ...] = ()


def _parts(model: ProcessModel) -> _Parts:
    """The model as a gain, a dead time, real lags, integrators and zeros; an inverse-
    response zero is already dead time (Skogestad 2003, eq. (8))."""
    p = {k: float(v) for k, v in model.params.items()}
    delay = p.get("delay", 0.0)
    steps: list[str] = []
    lags: list[float] = []
    lhp: list[float] = []
    osc = None
    s = model.structure
    if s == "first_order":
        lags = [p["T"]]
    elif s == "two_lags":
        lags = [p["T1"], p["T2"]]
    elif s == "n_lags":
        n, T = p["n"], p["T"]
        whole = int(math.floor(n))
        lags = [T] * whole + ([T * (n - whole)] if n > whole else [])
        if n > whole:
            steps.append(f"n = {n:.3g} equal lags of {T:.4g} s read as {whole} lags and one "
                         f"of {T * (n - whole):.4g} s")
    elif s == "second_order":
        zeta, wn = p["zeta"], p["wn"]
        if zeta >= 1.0:
            r = math.sqrt(zeta * zeta - 1.0)
            lags = [(zeta + r) / wn, (zeta - r) / wn]
        else:
            osc = (1.0 / wn, zeta)
    elif s == "lag_second_order":
        # no rule of Skogestad 2003 reads a lag and a lightly damped pair together; the
        # pair moves on the time scale max(2 zeta, 1)/wn (2 zeta/wn is the sum of its
        # time constants, 1/wn a lightly damped pair's own): read as a lag that long, for
        # the half rule. Its resonance is the tuning's worst case, which the check of the
        # settings over the interval sees (the exact response), not the reduction.
        zeta, wn = p["zeta"], p["wn"]
        pair = max(2.0 * zeta, 1.0) / wn
        lags = [p["T"], pair]
        steps.append(f"lightly damped pair (zeta {zeta:.3g}, wn {wn:.4g} rad/s) read as a "
                     f"lag of max(2 zeta, 1)/wn = {pair:.4g} s")
    elif s == "integrator":
        pass
    elif s == "integrator_lag":
        lags = [p["T"]]
    elif s in ("zero_two_lags", "lead_lag"):
        lags = [p["T1"], p["T2"]] if s == "zero_two_lags" else [p["T"]]
        tz = p["Tz"]
        if tz < 0:
            delay += -tz
            steps.append(f"inverse-response zero ({tz:.4g} s) taken as dead time "
                         f"{-tz:.4g} s")
        elif tz > 0:
            lhp = [tz]
    else:  # pragma: no cover - a new structure must say how it reduces
        raise ValueError(f"no reduction for structure {s!r}")
    return _Parts(p["K"], delay, tuple(sorted((x for x in lags if x > 0), reverse=True)),
                  1 if model.integrating else 0, tuple(lhp), osc, tuple(steps))


def _cancel_zero(parts: _Parts, theta: float) -> _Parts:
    """A left-half-plane zero against its nearest lag (Skogestad 2003, rules T1-T3 of
    eq. (10)); ``theta`` is the effective dead time the rules compare with."""
    if not parts.lhp_zeros:
        return parts
    t0, others = parts.lhp_zeros[0], parts.lhp_zeros[1:]
    lags = list(parts.lags)
    above = [x for x in lags if x >= t0]
    tau0 = min(above) if above else (max(lags) if lags else None)
    K, steps = parts.K, list(parts.steps)
    if tau0 is None:  # a zero and no lag: a lead; keep it out of the rule
        steps.append(f"zero ({t0:.4g} s) with no lag to cancel against: ignored")
        return _Parts(K, parts.delay, parts.lags, parts.integrators, others,
                      parts.oscillating, tuple(steps))
    lags.remove(tau0)
    theta = max(theta, 0.0)
    tilde = min(tau0, 5.0 * theta) if theta > 0 else tau0
    if t0 >= tau0 >= theta:
        K *= t0 / tau0
        rule = f"T1: gain x {t0 / tau0:.4g}"
    elif t0 >= theta >= tau0:
        K *= t0 / theta if theta > 0 else 1.0
        rule = f"T1a: gain x {t0 / theta:.4g}" if theta > 0 else "T1a"
    elif theta >= t0 >= tau0:
        rule = "T1b: zero and lag cancel"
    elif tau0 >= t0 >= 5.0 * theta:
        K *= t0 / tau0
        rule = f"T2: gain x {t0 / tau0:.4g}"
    else:  # tilde >= t0
        K *= tilde / tau0
        if tilde - t0 > 0:
            lags.append(tilde - t0)
        rule = f"T3: lag {tilde - t0:.4g} s, gain x {tilde / tau0:.4g}"
    steps.append(f"zero ({t0:.4g} s) against the lag {tau0:.4g} s, rule {rule}")
    return _Parts(K, parts.delay, tuple(sorted(lags, reverse=True)), parts.integrators,
                  others, parts.oscillating, tuple(steps))


def _half_rule(parts: _Parts, keep: int, h: float) -> tuple[list[float], float, list[str]]:
    """Keep ``keep`` lags (the largest; an integrator counts as the largest), the half
    rule for the rest (Skogestad 2003, eqs. (11)-(12)); ``h/2`` for the sample period."""
    lags = list(parts.lags)
    keep_lags = max(keep - parts.integrators, 0)
    kept, rest = lags[:keep_lags], lags[keep_lags:]
    theta = parts.delay + h / 2.0
    steps: list[str] = []
    if rest:
        half = rest[0] / 2.0
        if kept:
            kept[-1] += half
        theta += half + sum(rest[1:])
        steps.append(f"half rule: {len(rest)} smaller lag(s) ({', '.join(f'{x:.4g}' for x in rest)}"
                     f" s) to dead time {theta:.4g} s")
    if h > 0:
        steps.append(f"half the sample period ({h / 2:.4g} s) added to the dead time")
    return kept, theta, steps


def reduce(model: ProcessModel, order: int = 1, sample_time: float = 0.0) -> Reduced:
    """``model`` as a first-order (``order=1``) or second-order (``order=2``) model with an
    effective dead time, or its integrating counterpart (Skogestad 2003, Section 3).

    An oscillating second-order model (``zeta < 1``) stays oscillating (the rule for it
    reads ``tau0`` and ``zeta``; Skogestad 2003, Section 5, eq. (35)) when ``order=2``; as
    a first-order model it is read with ``tau1 = 2 zeta tau0`` (the sum of the time
    constants) and its dead time."""
    return _reduce(_parts(model), order, sample_time)


def reduce_lags(K: float, lags: tuple[float, ...], *, delay: float = 0.0,
                zeros: tuple[float, ...] = (), integrators: int = 0, order: int = 1,
                sample_time: float = 0.0) -> Reduced:
    """The half rule on any chain: gain ``K``, real ``lags`` (s), dead time ``delay``,
    numerator time constants ``zeros`` (``T0 s + 1``; negative: inverse response) and
    ``integrators`` (0 or 1). Skogestad 2003's Example E4 is
    ``reduce_lags(1, (2, 1, 0.4, 0.2, 0.05, 0.05, 0.05), zeros=(-0.3, 0.08))``."""
    steps: list[str] = []
    delay = float(delay)
    for z in (z for z in zeros if z < 0):
        delay += -z
        steps.append(f"inverse-response zero ({z:.4g} s) taken as dead time {-z:.4g} s")
    return _reduce(_Parts(float(K), delay, tuple(sorted((x for x in lags if x > 0),
                                                        reverse=True)),
                          integrators, tuple(sorted(z for z in zeros if z > 0)), None,
                          tuple(steps)), order, sample_time)


def _reduce(parts: _Parts, order: int, sample_time: float) -> Reduced:
    if order not in (1, 2):
        raise ValueError("order must be 1 or 2")
    h = max(float(sample_time or 0.0), 0.0)
    if parts.oscillating is not None:
        tau0, zeta = parts.oscillating
        theta = parts.delay + h / 2.0
        steps = parts.steps + ((f"half the sample period ({h / 2:.4g} s) added to the dead "
                                "time",) if h > 0 else ())
        if order == 2:
            return Reduced("oscillating", parts.K, theta, tau0, 0.0, zeta, steps)
        return Reduced("first_order", parts.K, theta, 2.0 * zeta * tau0, 0.0, 1.0,
                       steps + (f"oscillating pair read as one lag of 2 zeta/wn = "
                                f"{2 * zeta * tau0:.4g} s",))
    # the zero's rules compare with the dead time the half rule gives without it
    while parts.lhp_zeros:
        _, theta0, _ = _half_rule(parts, order, h)
        parts = _cancel_zero(parts, theta0)
    kept, theta, steps = _half_rule(parts, order, h)
    steps = list(parts.steps) + steps
    if parts.integrators:
        if kept:
            return Reduced("integrator_lag", parts.K, theta, kept[0], 0.0, 1.0, tuple(steps))
        return Reduced("integrator", parts.K, theta, 0.0, 0.0, 1.0, tuple(steps))
    tau1 = kept[0] if kept else 0.0
    tau2 = kept[1] if len(kept) > 1 else 0.0
    kind: ReducedKind = "second_order" if order == 2 and tau2 > 0 else "first_order"
    return Reduced(kind, parts.K, theta, tau1, tau2 if kind == "second_order" else 0.0,
                   1.0, tuple(steps))
