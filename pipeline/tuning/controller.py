"""A PID controller's settings and their forms: ideal (ISA), parallel and series.

The settings are held in one form, the ideal (ISA, "standard") form with a first-order
filter on the derivative term (Åström & Hägglund, *Advanced PID Control*, ISA 2006,
Section 3.2, eq. (3.3), and Section 3.3 for the filter)::

    C(s) = Kc (1 + 1/(Ti s) + Td s/(Tf s + 1)),     Tf = min(Td, Ti)/N,  N = 10

The filter is ``Td/N`` whenever ``Td <= Ti`` (every rule but one). SIMC's rule for an
oscillating process places the controller's complex zeros on the process's poles with
``Ti = 2 zeta tau0`` and ``Td = tau0/(2 zeta)`` (Skogestad 2003, eq. (35)), so ``Td/Ti =
1/(4 zeta^2)``: a filter ``Td/N`` would be slower than ``Ti`` itself once ``zeta < 0.16``
and move those zeros far off the poles (on ``zeta = 0.1``, ``theta = 0.1 tau0``: Ms 9.4
on the model itself; 1.75 with ``Tf = Ti/N``, 1.59 unfiltered). ``Tf = Ti/N`` keeps the
filter ten times faster than the fastest controller time.

The series ("interacting", "classical") form ``Kc' (1 + 1/(Ti' s)) (1 + Td' s)`` that
SIMC's second-order rule gives (Skogestad 2003, eq. (29)) converts exactly into the ideal
form (Åström & Hägglund 2006, eq. (3.8))::

    Kc = Kc' (1 + Td'/Ti'),   Ti = Ti' + Td',   Td = Ti' Td'/(Ti' + Td')

and back only when ``Ti >= 4 Td``. The parallel form is ``Kp = Kc``, ``Ki = Kc/Ti``,
``Kd = Kc Td``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

ControllerKind = Literal["P", "PI", "PID"]
CONTROLLER_KINDS: tuple[ControllerKind, ...] = ("P", "PI", "PID")

#: The derivative filter's N (Tf = Td/N; Ti/N when Ti < Td): Åström & Hägglund 2006,
#: Section 3.3, "N is typically in the range 8 to 20"; 10 is the value their examples use.
DERIVATIVE_FILTER_N = 10.0


@dataclass(frozen=True)
class Controller:
    """P, PI or PID settings in the ideal form (seconds): ``Ti`` is ``inf`` without integral
    action, ``Td`` 0 without derivative action, ``Tf`` the derivative filter's time
    constant. ``Kc`` carries the sign of the process gain (the error is ``r - y``)."""

    kind: ControllerKind
    Kc: float
    Ti: float = math.inf
    Td: float = 0.0
    Tf: float = 0.0

    @classmethod
    def ideal(cls, Kc: float, Ti: float = math.inf, Td: float = 0.0,
              n: float = DERIVATIVE_FILTER_N) -> Controller:
        """Ideal-form settings; the kind follows from which actions are present, the
        derivative filter is ``min(Td, Ti)/n`` (``Td/n`` unless ``Ti < Td``: see the module
        docstring)."""
        kind: ControllerKind = "PID" if Td > 0 else ("PI" if math.isfinite(Ti) else "P")
        tf = min(float(Td), float(Ti)) / n if Td > 0 else 0.0
        return cls(kind, float(Kc), float(Ti), float(Td), tf)

    @classmethod
    def series(cls, Kc: float, Ti: float, Td: float,
               n: float = DERIVATIVE_FILTER_N) -> Controller:
        """Series-form settings ``Kc (1 + 1/(Ti s)) (1 + Td s)`` as the ideal form
        (Åström & Hägglund 2006, eq. (3.8)); ``Ti = inf`` is a PD controller."""
        if Td <= 0:
            return cls.ideal(Kc, Ti)
        if not math.isfinite(Ti):
            return cls.ideal(Kc, math.inf, Td, n)
        return cls.ideal(Kc * (1.0 + Td / Ti), Ti + Td, Ti * Td / (Ti + Td), n)

    @property
    def integrating(self) -> bool:
        """Whether the controller has integral action (a pole at s = 0)."""
        return math.isfinite(self.Ti)

    def response(self, s: np.ndarray) -> np.ndarray:
        """C(s) at the complex points ``s`` (ideal form with the derivative filter)."""
        s = np.asarray(s, dtype=np.complex128)
        c = np.full_like(s, self.Kc)
        if self.integrating:
            # Kc/Ti first: an integral controller of a pure gain is the limit Kc, Ti -> 0
            # (SIMC gave Kc 5.0e-309, Ti 1e-309 s); 1/(Ti s) overflowed and the loop read
            # as unstable, Kc/Ti (5.0 /s) is its integral gain
            c = c + (self.Kc / self.Ti) / s
        if self.Td > 0:
            c = c + self.Kc * self.Td * s / (self.Tf * s + 1.0)
        return c

    def num_den(self) -> tuple[list[float], list[float]]:
        """C(s) as a ratio of polynomials in descending powers of s."""
        kc, ti, td, tf = self.Kc, self.Ti, self.Td, self.Tf
        if not self.integrating:
            if td <= 0:
                return [kc], [1.0]
            return [kc * (tf + td), kc], [tf, 1.0]
        if td <= 0:
            return [kc * ti, kc], [ti, 0.0]
        # Kc (Ti s (Tf s + 1) + (Tf s + 1) + Td Ti s^2) / (Ti s (Tf s + 1))
        return ([kc * ti * (tf + td), kc * (ti + tf), kc], [ti * tf, ti, 0.0])

    def parallel(self) -> dict[str, float]:
        """``Kp``, ``Ki`` (1/s), ``Kd`` (s): the parallel form."""
        return {"Kp": self.Kc, "Ki": self.Kc / self.Ti if self.integrating else 0.0,
                "Kd": self.Kc * self.Td}

    def as_series(self) -> dict[str, float] | None:
        """The series form's ``Kc``, ``Ti``, ``Td``, or None when the ideal settings have
        no series equivalent (``Ti < 4 Td``: complex controller zeros)."""
        if self.Td <= 0:
            return {"Kc": self.Kc, "Ti": self.Ti, "Td": 0.0}
        if not self.integrating:
            return {"Kc": self.Kc, "Ti": math.inf, "Td": self.Td}
        disc = 1.0 - 4.0 * self.Td / self.Ti
        if disc < 0:
            return None
        root = math.sqrt(disc)
        # the inverse of eq. (3.8): Ti' + Td' = Ti, Ti' Td' = Ti Td, Ti' the larger one
        ti_s = self.Ti * (1.0 + root) / 2.0
        td_s = self.Ti * (1.0 - root) / 2.0
        return {"Kc": self.Kc * ti_s / self.Ti, "Ti": ti_s, "Td": td_s}

    def with_gain(self, factor: float) -> Controller:
        """The same controller with its gain multiplied by ``factor``."""
        return Controller(self.kind, self.Kc * factor, self.Ti, self.Td, self.Tf)
