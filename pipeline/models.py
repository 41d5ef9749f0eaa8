"""``ProcessModel``: a low-order process model, its transfer function and step response.

Structures (parameter names as in DESIGN.md):

==============  ===========================================  ==================
structure       transfer function                            params
==============  ===========================================  ==================
first_order     K e^{-delay s} / (T s + 1)                   K, T, delay
second_order    K wn^2 e^{-delay s} / (s^2 + 2 zeta wn s + wn^2)  K, zeta, wn, delay
two_lags        K e^{-delay s} / ((T1 s + 1)(T2 s + 1))      K, T1, T2, delay
n_lags          K e^{-delay s} / (T s + 1)^n  (n may be non-integer, e.g. 2.5)  K, T, n, delay
==============  ===========================================  ==================

The unit step responses are closed forms (seed 000 section I; seed 001 "Underdamped 2nd
order step response"; the equal-lag response is the regularised lower incomplete gamma
function, exact also for non-integer n).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import gammainc

STRUCTURES: dict[str, tuple[str, ...]] = {
    "first_order": ("K", "T", "delay"),
    "second_order": ("K", "zeta", "wn", "delay"),
    "two_lags": ("K", "T1", "T2", "delay"),
    "n_lags": ("K", "T", "n", "delay"),
}

ORDER_CLASS = {"first_order": "first", "second_order": "second", "two_lags": "second"}


@dataclass(frozen=True)
class ProcessModel:
    """A process model: ``structure`` and ``params`` (names from :data:`STRUCTURES`)."""

    structure: str
    params: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.structure not in STRUCTURES:
            raise ValueError(f"unknown model structure {self.structure!r}")
        missing = [p for p in STRUCTURES[self.structure] if p != "delay" and p not in self.params]
        if missing:
            raise ValueError(f"{self.structure} model is missing {missing}")

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
        if self.structure == "n_lags":
            n = float(self.params["n"])
            return "first" if n == 1 else ("second" if n == 2 else "nth")
        return ORDER_CLASS[self.structure]

    def lags(self) -> list[float]:
        """Real time constants of the model, when it is a chain of real lags."""
        p = self.params
        if self.structure == "first_order":
            return [p["T"]]
        if self.structure == "two_lags":
            return [p["T1"], p["T2"]]
        if self.structure == "n_lags" and float(p["n"]).is_integer():
            return [p["T"]] * int(p["n"])
        if self.structure == "second_order" and p["zeta"] >= 1:
            r = math.sqrt(p["zeta"] ** 2 - 1)
            return [1 / (p["wn"] * (p["zeta"] - r)), 1 / (p["wn"] * (p["zeta"] + r))]
        return []

    # -- responses ----------------------------------------------------------------------
    def unit_step(self, t: np.ndarray) -> np.ndarray:
        """Response to a unit step at t = 0 (deviation variables), delay included."""
        t = np.asarray(t, dtype=np.float64) - self.delay
        out = np.zeros_like(t)
        pos = t > 0
        out[pos] = self.K * _unit_lag_response(self.structure, self.params, t[pos])
        return out

    def simulate(self, t, u, u0: float, y0: float) -> np.ndarray:
        """Output for input ``u`` (zero-order hold) from the steady operating point (u0, y0)."""
        from .simulate import simulate

        return simulate(self, t, u, u0, y0)

    # -- transfer function --------------------------------------------------------------
    def num_den(self) -> tuple[list[float], list[float]] | None:
        """Numerator and denominator in descending powers of s (None if n is non-integer)."""
        p = self.params
        K = p["K"]
        if self.structure == "first_order":
            return [K], [p["T"], 1.0]
        if self.structure == "second_order":
            wn, z = p["wn"], p["zeta"]
            return [K * wn**2], [1.0, 2 * z * wn, wn**2]
        if self.structure == "two_lags":
            return [K], [p["T1"] * p["T2"], p["T1"] + p["T2"], 1.0]
        n = float(p["n"])
        if not n.is_integer():
            return None
        den = np.poly1d([1.0])
        for _ in range(int(n)):
            den = den * np.poly1d([p["T"], 1.0])
        return [K], [float(c) for c in den.coeffs]

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
        g = lambda v: f"{v:.{digits}g}"  # noqa: E731
        if self.structure == "first_order":
            s = f"{g(p['K'])}/({g(p['T'])}s+1)"
        elif self.structure == "second_order":
            wn = p["wn"]
            s = f"{g(p['K'] * wn**2)}/(s^2+{g(2 * p['zeta'] * wn)}s+{g(wn**2)})"
        elif self.structure == "two_lags":
            s = f"{g(p['K'])}/(({g(p['T1'])}s+1)({g(p['T2'])}s+1))"
        else:
            s = f"{g(p['K'])}/({g(p['T'])}s+1)^{g(p['n'])}"
        if p.get("delay", 0.0) > 0:
            s += f" e^(-{g(p['delay'])}s)"
        return s


def _unit_lag_response(structure: str, p: dict, t: np.ndarray) -> np.ndarray:
    """Unit-gain step response of the rational part at times ``t > 0``."""
    if structure == "first_order":
        return -np.expm1(-t / p["T"])
    if structure == "two_lags":
        return two_lag_step(t, p["T1"], p["T2"])
    if structure == "n_lags":
        return gammainc(float(p["n"]), t / p["T"])
    return second_order_step(t, p["zeta"], p["wn"])


def two_lag_step(t: np.ndarray, T1: float, T2: float) -> np.ndarray:
    """Unit step response of 1/((T1 s+1)(T2 s+1)); equal lags and T2 = 0 handled exactly."""
    T1, T2 = max(T1, T2), min(T1, T2)
    if T2 <= 0:
        return -np.expm1(-t / T1) if T1 > 0 else np.ones_like(t)
    if abs(T1 - T2) <= 1e-9 * T1:
        return gammainc(2.0, t / T1)
    return 1.0 - (T1 * np.exp(-t / T1) - T2 * np.exp(-t / T2)) / (T1 - T2)


def second_order_step(t: np.ndarray, zeta: float, wn: float) -> np.ndarray:
    """Unit step response of wn^2/(s^2+2 zeta wn s+wn^2) (seed 001, underdamped formula)."""
    if zeta < 1:
        wd = wn * math.sqrt(1 - zeta**2)
        return 1.0 - np.exp(-zeta * wn * t) * (
            np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)
        )
    if zeta == 1:
        return gammainc(2.0, wn * t)
    r = math.sqrt(zeta**2 - 1)
    return two_lag_step(t, 1 / (wn * (zeta - r)), 1 / (wn * (zeta + r)))
