"""What a closed loop's own log says about its controller (issue 32 item 1): a log with
the setpoint ``r`` beside the measurement ``y`` and the controller output ``u``
(``data.setpoint``).

* :func:`read_loop` - the running controller's settings (:func:`pipeline.tuning.
  identify_controller`) and, for each setpoint step of a loop under P control, PI
  settings by the setpoint overshoot method (:func:`pipeline.tuning.setpoint_overshoot_pi`,
  Shamsuzzoha & Skogestad 2010), each with the reason where it cannot be read;
* :func:`with_plant` - the plant fitted through the loop with the running controller (the
  indirect approach, :func:`pipeline.refine.fit_through_loop`), from the direct fit;
* :func:`setpoint_steps` - where the setpoint steps, and by how much.

Pure functions of numpy arrays; the analysis (:mod:`pipeline.analysis`) calls
:func:`read_loop` on a record that has a setpoint.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ..refine import ClosedLoopFit, fit_through_loop
from .controller import Controller
from .overshoot import OvershootTest, read_setpoint_step, setpoint_overshoot_pi
from .running import RunningController, identify_controller

#: A change of the setpoint between two samples is a step when it is at least this share
#: of the setpoint's range (a setpoint is piecewise constant; a ramped setpoint has no
#: step to read an overshoot from).
STEP_SHARE = 0.05
#: The running controller is known well enough to fit the plant through the loop when its
#: settings explain the controller output to within this share of its spread.
CONTROLLER_SHARE = 0.05
#: The response to a setpoint step has settled when the means of the window's last two
#: tenths differ by at most this share of the step (else the steady change is read from
#: the first swing, the method's eq. 18).
SETTLED_SHARE = 0.02


@dataclass(frozen=True)
class SetpointStep:
    """One setpoint step at ``time`` (s) of ``change``, and what the setpoint overshoot
    method made of it: the ``test`` read and the PI ``controller``, or the ``reason``
    it could not (the loop is not under P control, no overshoot, ...)."""

    time: float
    change: float
    test: OvershootTest | None = None
    controller: Controller | None = None
    reason: str | None = None


@dataclass(frozen=True)
class LoopReading:
    """A closed loop read off its log: the ``setpoint``'s name, the ``running``
    controller (None with ``reason`` when it cannot be read), the setpoint ``steps``, and
    the ``plant`` fitted through the loop with that controller (:func:`with_plant`; None
    with ``plant_reason``, or not asked for: both None)."""

    setpoint: str
    running: RunningController | None
    reason: str | None
    steps: tuple[SetpointStep, ...] = ()
    plant: ClosedLoopFit | None = None
    plant_reason: str | None = None


def setpoint_steps(r: np.ndarray) -> list[tuple[int, float]]:
    """``(sample index, change)`` of each step of the setpoint ``r``: a change between two
    samples of at least :data:`STEP_SHARE` of its range."""
    r = np.asarray(r, np.float64)
    span = float(np.ptp(r)) if r.size else 0.0
    if not span > 0:
        return []
    d = np.diff(r)
    return [(int(k) + 1, float(d[k])) for k in np.flatnonzero(np.abs(d) >= STEP_SHARE * span)]


def read_loop(t, r, y, u, *, setpoint: str = "r") -> LoopReading:
    """The running controller and the setpoint steps' PI settings of a log (module
    docstring). Never raises for what the data lack: each part says why it is missing."""
    t, r, y, u = (np.asarray(a, np.float64) for a in (t, r, y, u))
    try:
        running, reason = identify_controller(t, r, y, u), None
    except ValueError as exc:
        running, reason = None, str(exc)
    return LoopReading(setpoint, running, reason, tuple(_steps(t, r, y, running)))


def with_plant(reading: LoopReading, t, r, y, structure: str,
               start: Mapping[str, float]) -> LoopReading:
    """``reading`` with the plant ``structure`` fitted through the loop, the running
    controller known (the indirect approach, :func:`pipeline.refine.fit_through_loop`),
    started at ``start`` (the direct fit's parameters); the reason where it cannot be."""
    if reading.running is None:
        return replace(reading, plant_reason="the running controller could not be read")
    if reading.running.residual_share > CONTROLLER_SHARE:
        return replace(reading, plant_reason=(
            f"the controller's settings explain the controller output only to "
            f"{100 * reading.running.residual_share:.2g} % (limits, quantisation or another "
            "form): the loop is not known well enough to fit the plant through it"))
    try:
        fit = fit_through_loop(t, r, y, reading.running.controller, structure, start)
    except ValueError as exc:
        return replace(reading, plant_reason=str(exc))
    return replace(reading, plant=fit)


def _steps(t: np.ndarray, r: np.ndarray, y: np.ndarray, running: RunningController | None
           ) -> list[SetpointStep]:
    steps = setpoint_steps(r)
    out = []
    for j, (k, change) in enumerate(steps):
        end = steps[j + 1][0] if j + 1 < len(steps) else t.size
        if running is None:
            out.append(SetpointStep(float(t[k]), change, reason="the running controller "
                                    "could not be read"))
            continue
        c = running.controller
        if c.kind != "P":
            out.append(SetpointStep(float(t[k]), change, reason=(
                f"the loop runs under {c.kind} control; the setpoint overshoot method reads "
                "a step under P control")))
            continue
        prev = steps[j - 1][0] if j else 0
        start = max(prev, k - (end - k) // 4)  # the baseline: the end of the window before
        tw, yw = t[start:end], y[start:end]
        try:
            test = read_setpoint_step(tw, yw, float(t[k]), change, c.Kc,
                                      settled=_settled(y[k:end], change))
            out.append(SetpointStep(float(t[k]), change, test, setpoint_overshoot_pi(test)))
        except ValueError as exc:
            out.append(SetpointStep(float(t[k]), change, reason=str(exc)))
    return out


def _settled(after: np.ndarray, change: float) -> bool:
    """Whether the response ``after`` a step of ``change`` has settled by the window's
    end: its last two tenths' means within :data:`SETTLED_SHARE` of the step."""
    m = after.size // 10
    if m < 2:
        return False
    last, before = float(np.mean(after[-m:])), float(np.mean(after[-2 * m: -m]))
    return math.isfinite(last) and abs(last - before) <= SETTLED_SHARE * abs(change)
