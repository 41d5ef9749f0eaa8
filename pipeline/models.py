"""The model vocabulary, written down once: the parameter table, the structure table and
:class:`ProcessModel` (DESIGN.md "Vocabulary").

Every other module reads these tables: simulation (the step response), the reports
(labels, units, number formats, the overlay view), the regression gate (tolerance class
and scale of each parameter), the history (one column per parameter) and the results
schema. Adding a structure is one :class:`Structure` entry plus its response function;
adding a parameter is one :class:`Parameter` entry.

==============  =================================================  ======================
structure       transfer function                                  params
==============  =================================================  ======================
first_order     K e^{-delay s} / (T s + 1)                         K, T, delay
second_order    K wn^2 e^{-delay s} / (s^2 + 2 zeta wn s + wn^2)   K, zeta, wn, delay
two_lags        K e^{-delay s} / ((T1 s + 1)(T2 s + 1))            K, T1, T2, delay
n_lags          K e^{-delay s} / (T s + 1)^n  (n may be non-integer)  K, T, n, delay
integrator      K e^{-delay s} / s                                 K, delay
integrator_lag  K e^{-delay s} / (s (T s + 1))                     K, T, delay
zero_two_lags   K (Tz s + 1) e^{-delay s} / ((T1 s + 1)(T2 s + 1))  K, Tz, T1, T2, delay
lead_lag        K (Tz s + 1) e^{-delay s} / (T s + 1)              K, Tz, T, delay
lag_second_order  K wn^2 e^{-delay s} / ((T s + 1)(s^2 + 2 zeta wn s + wn^2))
                                                                   K, T, zeta, wn, delay
==============  =================================================  ======================

``lag_second_order`` is a lag behind a lightly damped pair (``zeta < 1``: Åström &
Hägglund's oscillatory benchmark plant, a flexible drive behind a motor's lag). It is
fitted only to a response that rings (``rings=True``): elsewhere its pair is not
determined by the data.

An integrator's gain is per time unit (:meth:`Parameter.unit`, ``integrating=True``);
``Tz < 0`` is an inverse response; a lead-lag's step response jumps to ``K Tz/T`` at the
dead time (:meth:`ProcessModel.unit_step` is right-continuous there, as scipy's ZOH).

The unit step responses are closed forms (seed 000 section I; seed 001 "Underdamped 2nd
order step response"; the equal-lag response is the regularised lower incomplete gamma
function, exact also for non-integer n).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.special import gammainc

from .responses import (
    integrator_lag_step,
    lag_pair_step,
    lead_lag_step,
    second_order_step,
    two_lag_impulse,
    two_lag_step,
    zero_lags_time_scale,
)

# =====================================================================================
# Parameters
# =====================================================================================

#: Unit kinds of a parameter (how its unit follows from the record's units).
UNIT_KINDS = ("gain", "time", "dimensionless", "frequency")


@dataclass(frozen=True)
class Parameter:
    """One model parameter: its meaning, unit kind, regression tolerance and display.

    ``tolerance`` is the baseline tolerance class: "gain" parameters get the gate's
    ``param_tol``, "dynamics" parameters a multiple of it (a step pins the gain to a ratio
    of two averaged plateaus, the dynamics to a few samples of the transient).
    ``scale`` says what a change is measured against in the gate: "value" (the baseline
    value itself, at least ``floor``), "time_scale" (the model's time scale: a dead time
    of 0 that becomes 0.05 s on a 5 s lag is a 1 % change) or "dominant_lag" (the larger
    of T1 and T2: a minor lag is poorly determined by a step).
    """

    name: str
    kind: str
    label: str
    tolerance: str = "dynamics"
    scale: str = "value"
    floor: float = 0.0
    digits: int = 4
    lag: bool = False  # the time constant of a lag (the dominant one sets the speed)

    def unit(self, units: Mapping[str, str] | None = None, *, integrating: bool = False
             ) -> str:
        """The unit of this parameter for a record with ``units`` (keys time, input,
        output); the gain of an integrating structure is per time unit."""
        units = units or {}
        time = units.get("time") or "s"
        if self.kind == "gain":
            out, inp = units.get("output"), units.get("input")
            base = f"{out or '-'}/{inp or '-'}" if (out or inp) else ""
            if integrating:
                return f"{base}/{time}" if base else f"1/{time}"
            return base
        if self.kind == "time":
            return time
        if self.kind == "frequency":
            return f"rad/{time}"
        return ""

    def time_power(self, integrating: bool = False) -> int:
        """How the value scales with the time unit: +1 a time, -1 a rate (a frequency, the
        gain of an integrator), 0 otherwise."""
        if self.kind == "time":
            return 1
        if self.kind == "frequency" or (self.kind == "gain" and integrating):
            return -1
        return 0

    def format(self, value: float, digits: int | None = None) -> str:
        """``value`` with this parameter's significant digits (integers stay integers)."""
        v = float(value)
        if self.name == "n" and v.is_integer():
            return str(int(v))
        return f"{v:.{digits or self.digits}g}"


PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    Parameter("K", "gain", "gain K", tolerance="gain"),
    # a zero may be near 0 or change sign: its change is measured on the model's time scale
    Parameter("Tz", "time", "zero time constant Tz", scale="time_scale"),
    Parameter("T", "time", "time constant T", lag=True),
    Parameter("T1", "time", "time constant T1", scale="dominant_lag", lag=True),
    Parameter("T2", "time", "time constant T2", scale="dominant_lag", lag=True),
    Parameter("n", "dimensionless", "order n"),
    Parameter("zeta", "dimensionless", "damping zeta", floor=0.1),
    Parameter("wn", "frequency", "natural frequency wn"),
    Parameter("delay", "time", "dead time", scale="time_scale"),
)}


def _second_order_lags(p: Mapping[str, float]) -> list[float]:
    if p["zeta"] < 1:
        return []
    r = math.sqrt(p["zeta"] ** 2 - 1)
    return [1 / (p["wn"] * (p["zeta"] - r)), 1 / (p["wn"] * (p["zeta"] + r))]


def _poly_power(base: list[float], n: int) -> list[float]:
    den = np.poly1d([1.0])
    for _ in range(n):
        den = den * np.poly1d(base)
    return [float(c) for c in den.coeffs]


def _g(v: float, digits: int) -> str:
    return f"{float(v):.{digits}g}"


def _pair_text(p: Mapping[str, float], digits: int) -> str:
    """``Tw^2 s^2 + 2 zeta Tw s + 1`` with ``Tw = 1/wn`` in numbers (``inf`` at wn = 0)."""
    tw = 1.0 / p["wn"] if p["wn"] > 0 else math.inf
    return f"{_g(tw * tw, digits)}s^2+{_g(2.0 * p['zeta'] * tw, digits)}s+1"


# =====================================================================================
# Structures
# =====================================================================================

Params = Mapping[str, float]


@dataclass(frozen=True)
class Structure:
    """One model structure: its parameters and everything derived from them.

    ``step(p, t)``: the unit-gain step response of the rational part at times ``t >= 0``
    (``t = 0`` means 0+; the model adds K and the delay). ``num_den(p)``: numerator and
    denominator in descending powers of s, gain included (None when there is no rational
    form, e.g. a non-integer n). ``time_scale(p)``: the sum of the time constants (mean
    residence time; with a right-half-plane zero ``- Tz`` is added), the horizon the gate
    measures against. An integrating structure (``integrating=True``: the step response
    ramps, the gain is per time unit) has no residence time; its time scale is how far
    the final ramp lags an ideal integrator, ``T + delay`` (where the ramp's asymptote
    crosses the initial level). ``bounds``: physical limits of each parameter
    (refinement searches inside them). ``rings``: the structure holds a lightly damped
    pair that only a ringing response determines, and is fitted only to one
    (:func:`pipeline.methods.second_order.light_ring`).
    """

    name: str
    params: tuple[str, ...]
    formula: str
    step: Callable[[Params, np.ndarray], np.ndarray]
    num_den: Callable[[Params], tuple[list[float], list[float]] | None]
    text: Callable[[Params, int], str]
    time_scale: Callable[[Params], float]
    order_class: Callable[[Params], str]
    lags: Callable[[Params], list[float]] = lambda p: []
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    integrating: bool = False
    rings: bool = False

    @property
    def dynamics(self) -> tuple[str, ...]:
        """The parameters other than the gain and the dead time."""
        return tuple(p for p in self.params if p not in ("K", "delay"))


_POSITIVE = (0.0, math.inf)
#: The largest damping ratio of ``lag_second_order``'s pair.
ZETA_MAX = 0.99
_BOUNDS_DELAY = {"K": (-math.inf, math.inf), "delay": (0.0, math.inf)}

STRUCTURES: dict[str, Structure] = {s.name: s for s in (
    Structure(
        "first_order", ("K", "T", "delay"), "K e^(-delay s)/(T s+1)",
        step=lambda p, t: -np.expm1(-t / p["T"]),
        num_den=lambda p: ([p["K"]], [p["T"], 1.0]),
        text=lambda p, d: f"{_g(p['K'], d)}/({_g(p['T'], d)}s+1)",
        time_scale=lambda p: abs(p["T"]),
        order_class=lambda p: "first",
        lags=lambda p: [p["T"]],
        bounds={**_BOUNDS_DELAY, "T": _POSITIVE},
    ),
    Structure(
        "second_order", ("K", "zeta", "wn", "delay"),
        "K e^(-delay s)/(s^2/wn^2+2 zeta s/wn+1)",
        step=lambda p, t: second_order_step(t, p["zeta"], p["wn"]),
        num_den=lambda p: ([p["K"] * p["wn"] ** 2], [1.0, 2 * p["zeta"] * p["wn"],
                                                     p["wn"] ** 2]),
        # the time-constant form K/(Tw^2 s^2 + 2 zeta Tw s + 1), Tw = 1/wn (as MATLAB's
        # idproc prints it): the gain is read off the text
        text=lambda p, d: f"{_g(p['K'], d)}/({_pair_text(p, d)})",
        # 2 zeta/wn is the sum of the time constants; a lightly damped pair still moves
        # on the time scale 1/wn
        time_scale=lambda p: max(2.0 * p["zeta"], 1.0) / p["wn"] if p["wn"] > 0 else math.nan,
        order_class=lambda p: "second",
        lags=_second_order_lags,
        bounds={**_BOUNDS_DELAY, "zeta": (0.0, 50.0), "wn": _POSITIVE},
    ),
    Structure(
        "two_lags", ("K", "T1", "T2", "delay"), "K e^(-delay s)/((T1 s+1)(T2 s+1))",
        step=lambda p, t: two_lag_step(t, p["T1"], p["T2"]),
        num_den=lambda p: ([p["K"]], [p["T1"] * p["T2"], p["T1"] + p["T2"], 1.0]),
        text=lambda p, d: f"{_g(p['K'], d)}/(({_g(p['T1'], d)}s+1)({_g(p['T2'], d)}s+1))",
        time_scale=lambda p: abs(p["T1"]) + abs(p["T2"]),
        order_class=lambda p: "second",
        lags=lambda p: [p["T1"], p["T2"]],
        bounds={**_BOUNDS_DELAY, "T1": _POSITIVE, "T2": _POSITIVE},
    ),
    Structure(
        "n_lags", ("K", "T", "n", "delay"), "K e^(-delay s)/(T s+1)^n",
        step=lambda p, t: gammainc(float(p["n"]), t / p["T"]),
        num_den=lambda p: (([p["K"]], _poly_power([p["T"], 1.0], int(p["n"])))
                           if float(p["n"]).is_integer() else None),
        text=lambda p, d: f"{_g(p['K'], d)}/({_g(p['T'], d)}s+1)" + (
            "" if float(p["n"]) == 1.0 else f"^{_g(p['n'], d)}"),
        time_scale=lambda p: abs(p["T"]) * max(float(p["n"]), 0.0),
        order_class=lambda p: {1.0: "first", 2.0: "second"}.get(float(p["n"]), "nth"),
        lags=lambda p: [p["T"]] * int(p["n"]) if float(p["n"]).is_integer() else [],
        bounds={**_BOUNDS_DELAY, "T": _POSITIVE, "n": (1.0, 20.0)},
    ),
    Structure(
        "integrator", ("K", "delay"), "K e^(-delay s)/s",
        step=lambda p, t: np.asarray(t, dtype=np.float64),
        num_den=lambda p: ([p["K"]], [1.0, 0.0]),
        text=lambda p, d: f"{_g(p['K'], d)}/s",
        time_scale=lambda p: abs(p.get("delay", 0.0)),
        order_class=lambda p: "first",
        bounds=dict(_BOUNDS_DELAY),
        integrating=True,
    ),
    Structure(
        "integrator_lag", ("K", "T", "delay"), "K e^(-delay s)/(s(T s+1))",
        step=lambda p, t: integrator_lag_step(t, p["T"]),
        num_den=lambda p: ([p["K"]], [p["T"], 1.0, 0.0]),
        text=lambda p, d: f"{_g(p['K'], d)}/(s({_g(p['T'], d)}s+1))",
        time_scale=lambda p: abs(p["T"]) + abs(p.get("delay", 0.0)),
        order_class=lambda p: "second",
        lags=lambda p: [p["T"]],
        bounds={**_BOUNDS_DELAY, "T": _POSITIVE},
        integrating=True,
    ),
    Structure(
        "zero_two_lags", ("K", "Tz", "T1", "T2", "delay"),
        "K (Tz s+1) e^(-delay s)/((T1 s+1)(T2 s+1))",
        step=lambda p, t: (two_lag_step(t, p["T1"], p["T2"])
                           + p["Tz"] * two_lag_impulse(t, p["T1"], p["T2"])),
        num_den=lambda p: ([p["K"] * p["Tz"], p["K"]],
                           [p["T1"] * p["T2"], p["T1"] + p["T2"], 1.0]),
        text=lambda p, d: (f"{_g(p['K'], d)}({_g(p['Tz'], d)}s+1)/(({_g(p['T1'], d)}s+1)"
                           f"({_g(p['T2'], d)}s+1))"),
        time_scale=lambda p: zero_lags_time_scale(abs(p["T1"]) + abs(p["T2"]), p["Tz"]),
        order_class=lambda p: "second",
        lags=lambda p: [p["T1"], p["T2"]],
        bounds={**_BOUNDS_DELAY, "Tz": (-math.inf, math.inf), "T1": _POSITIVE,
                "T2": _POSITIVE},
    ),
    Structure(
        "lead_lag", ("K", "Tz", "T", "delay"), "K (Tz s+1) e^(-delay s)/(T s+1)",
        step=lambda p, t: lead_lag_step(t, p["Tz"], p["T"]),
        num_den=lambda p: ([p["K"] * p["Tz"], p["K"]], [p["T"], 1.0]),
        text=lambda p, d: f"{_g(p['K'], d)}({_g(p['Tz'], d)}s+1)/({_g(p['T'], d)}s+1)",
        time_scale=lambda p: zero_lags_time_scale(abs(p["T"]), p["Tz"]),
        order_class=lambda p: "first",
        lags=lambda p: [p["T"]],
        bounds={**_BOUNDS_DELAY, "Tz": (-math.inf, math.inf), "T": _POSITIVE},
    ),
    Structure(
        "lag_second_order", ("K", "T", "zeta", "wn", "delay"),
        "K e^(-delay s)/((T s+1)(s^2/wn^2+2 zeta s/wn+1))",
        step=lambda p, t: lag_pair_step(t, p["T"], p["zeta"], p["wn"]),
        # (T s + 1)(s^2/wn^2 + 2 zeta s/wn + 1): the gain alone in the numerator
        num_den=lambda p: ([p["K"]], [p["T"] / p["wn"] ** 2,
                                      (2 * p["zeta"] * p["T"] * p["wn"] + 1) / p["wn"] ** 2,
                                      p["T"] + 2 * p["zeta"] / p["wn"], 1.0]),
        text=lambda p, d: f"{_g(p['K'], d)}/(({_g(p['T'], d)}s+1)({_pair_text(p, d)}))",
        # the lag's time constant and the pair's time scale (as second_order's)
        time_scale=lambda p: abs(p["T"]) + (max(2.0 * p["zeta"], 1.0) / p["wn"]
                                            if p["wn"] > 0 else math.nan),
        order_class=lambda p: "nth",
        lags=lambda p: [p["T"]],
        # a lightly damped pair: zeta stays clear of 1 (a critically damped pair is two
        # lags, which two_lags and n_lags hold, and the closed form divides by wd)
        bounds={**_BOUNDS_DELAY, "T": _POSITIVE, "zeta": (0.0, ZETA_MAX), "wn": _POSITIVE},
        rings=True,
    ),
)}


def delayed_step(spec: Structure, p: Params, t) -> np.ndarray:
    """The unit-gain step response of ``spec`` with the dead time ``p["delay"]`` at times
    ``t`` (0 before the dead time): the one delayed step every simulation, regressor and
    filter head is made of. Right-continuous at the dead time (``S(delay) = S(delay+)``,
    as scipy's ZOH: a lead-lag's jump is seen at the sample where the delayed step
    arrives); times within 1e-12 (relative) of the dead time count as on it."""
    t = np.asarray(t, dtype=np.float64)
    delay = float(p.get("delay", 0.0))
    tau = t - delay
    out = np.zeros_like(tau)
    eps = 1e-12 * max(1.0, abs(delay), float(np.max(np.abs(t))) if t.size else 0.0)
    pos = tau >= -eps
    out[pos] = spec.step(p, np.maximum(tau[pos], 0.0))
    return out


# =====================================================================================
# ProcessModel
# =====================================================================================

@dataclass(frozen=True)
class ProcessModel:
    """A process model: ``structure`` (a key of :data:`STRUCTURES`) and its ``params``."""

    structure: str
    params: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.structure not in STRUCTURES:
            raise ValueError(f"unknown model structure {self.structure!r}")
        missing = [p for p in self.spec.params if p != "delay" and p not in self.params]
        if missing:
            raise ValueError(f"{self.structure} model is missing {missing}")

    @property
    def spec(self) -> Structure:
        """The structure table entry of this model."""
        return STRUCTURES[self.structure]

    # -- parameters ---------------------------------------------------------------------
    @property
    def K(self) -> float:
        return float(self.params["K"])

    @property
    def delay(self) -> float:
        return float(self.params.get("delay", 0.0))

    @property
    def order_class(self) -> str:
        """"first", "second" or "nth": the three overlay views of the report."""
        return self.spec.order_class(self.params)

    @property
    def integrating(self) -> bool:
        """True when the step response ramps (the gain is per time unit)."""
        return self.spec.integrating

    @property
    def time_scale(self) -> float:
        """The sum of the model's time constants (seconds), see :class:`Structure`."""
        return float(self.spec.time_scale(self.params))

    def lags(self) -> list[float]:
        """Real time constants of the model's lags (an underdamped pair has none)."""
        return [float(v) for v in self.spec.lags(self.params)]

    # -- responses ----------------------------------------------------------------------
    def unit_step(self, t: np.ndarray) -> np.ndarray:
        """Response to a unit step at t = 0 (deviation variables), delay included.

        Right-continuous at the dead time (``S(delay) = S(delay+)``): a lead-lag's jump
        is seen at the sample where the delayed step arrives, as in scipy's ZOH
        discretisation. Times within 1e-12 (relative) of the dead time count as on it.
        """
        return self.K * delayed_step(self.spec, self.params, t)

    # -- transfer function --------------------------------------------------------------
    def num_den(self) -> tuple[list[float], list[float]] | None:
        """Numerator and denominator in descending powers of s (None if n is non-integer)."""
        return self.spec.num_den(self.params)

    def transfer_function(self):
        """``control.TransferFunction`` of the rational part (the delay is kept beside it)."""
        import control

        nd = self.num_den()
        if nd is None:
            raise ValueError("a non-integer order n has no rational transfer function")
        return control.tf(*nd)

    def to_dict(self) -> dict:
        """The results.json form: num, den, delay and a readable text."""
        nd = self.num_den()
        return {
            "num": nd[0] if nd else None,
            "den": nd[1] if nd else None,
            "delay": self.delay,
            "text": self.text(),
        }

    def text(self, digits: int = 4) -> str:
        """A compact readable transfer function, e.g. ``20.7/(61.2s+1) e^(-2s)``."""
        p = {k: float(v) for k, v in self.params.items()}
        s = self.spec.text(p, digits)
        if p.get("delay", 0.0) > 0:
            s += f" e^(-{_g(p['delay'], digits)}s)"
        return s
