"""``Fit``, ``Flag`` and a refinement's summary: the outcome of one method on one event
(DESIGN.md "Core types").

A graphical reading carries the points it read in ``diagnostics``; a least-squares
refinement carries a typed :class:`RefinementSummary` in ``refinement`` (how its initial
state was treated, its fitted operating point, its own fit error and effective sample
size, its folds), which validation, grading and the recommendation read by attribute.
:attr:`Fit.is_refined` is the one rule for "is this fit a refinement".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from .models import ProcessModel
from .schema import FitStatus, Severity, Verdict

#: The verdicts, best first (the literal is the schema's).
VERDICTS: tuple[str, ...] = get_args(Verdict)

#: How a simulated span's initial state starts: at rest at the input level before it,
#: "estimated" (its free response fitted), or, for an integrating structure on a steady
#: ramp, "steady" (the lags at equilibrium, the balance point fitted).
InitialState = Literal["rest", "estimated", "steady"]
#: How a refinement's state was treated, as its summary tells it: one of
#: :data:`InitialState`, or "carried" through the record from an earlier event that
#: started at rest.
StateTreatment = Literal["rest", "estimated", "steady", "carried"]
#: How a cross-validation fold's model was obtained.
Refit = Literal["exact", "gauss-newton"]


@dataclass(frozen=True)
class Flag:
    """One reason behind a verdict: a stable ``code``, a plain-words ``message`` and the
    numbers it was decided on."""

    code: str
    message: str
    values: dict[str, float | str | None] = field(default_factory=dict)
    severity: Severity = "warning"  # the verdict it forces at least


@dataclass(frozen=True)
class Fold:
    """One cross-validation fold of a fit over several events: the ``events`` held out,
    the model refitted without them (``params``; ``u0`` an integrating model's balance
    point), its error on them (``mse``) and how it was refitted."""

    events: tuple[int, ...]
    params: dict[str, float]
    u0: float | None
    mse: float
    refit: Refit


@dataclass(frozen=True)
class ParameterCovariance:
    """The covariance behind a refinement's intervals, in its search coordinates: for each
    of ``names`` (the searched parameters, then ``K``) the coordinate is the log of the
    parameter (``log``) or the parameter over ``scale``; ``z`` the coordinates at the fit,
    ``matrix`` their covariance (the profiled Jacobian's, with the coloured-noise factor:
    :func:`pipeline.uncertainty.covariance`). :meth:`draws` are parameter sets the data
    allow, correlations included (the interval of each parameter alone ignores them)."""

    names: tuple[str, ...]
    log: tuple[bool, ...]
    scale: tuple[float, ...]
    z: tuple[float, ...]
    matrix: tuple[tuple[float, ...], ...]

    def draws(self, n: int, seed: int = 0) -> list[dict[str, float]]:
        """``n`` parameter sets from the normal distribution of the coordinates (fixed
        ``seed``: the same draws every time), mapped back to the parameters."""
        rng = np.random.default_rng(seed)
        cov = np.asarray(self.matrix, dtype=np.float64)
        # the symmetric part's eigen-decomposition, rounding's negative eigenvalues at 0
        w, vecs = np.linalg.eigh((cov + cov.T) / 2.0)
        zs = np.asarray(self.z) + (rng.standard_normal((n, w.size)) * np.sqrt(
            np.maximum(w, 0.0))) @ vecs.T
        return [self.at(row) for row in zs]

    def at(self, z: np.ndarray) -> dict[str, float]:
        """The parameters at search coordinates ``z`` (a log coordinate's exponential,
        a linear one times its scale)."""
        log, scale = np.asarray(self.log), np.asarray(self.scale)
        with np.errstate(over="ignore"):
            v = np.where(log, np.exp(np.minimum(z, 700.0)), np.asarray(z) * scale)
        return dict(zip(self.names, map(float, v), strict=True))


@dataclass(frozen=True)
class RowSensitivity:
    """How a refinement's estimates move with its criterion rows' noise, kept only until
    the held-out residuals widen its intervals (:mod:`pipeline.refine.heldout_noise`):
    ``rows``, the profiled pseudo-inverse (one row per coordinate of its
    :class:`ParameterCovariance`, one column per criterion row, the rows consecutive in
    time), ``samples`` fit samples per criterion row (block means beyond the refinement's
    ``max_rows``), and the t ``quantile`` of its intervals; ``pair``, two coincident lags'
    coordinates whose rows are in ``(m, w)`` (:mod:`pipeline.refine.coincident`)."""

    rows: np.ndarray
    samples: int
    quantile: float
    pair: tuple[int, int] | None = None


@dataclass(frozen=True)
class RefinementSummary:
    """What a least-squares refinement says about itself, beside its model and intervals.

    ``state`` and ``carried_from`` (the event the state was carried from, when
    "carried"); the fitted operating point (offset ``y0``, input balance point ``u0``:
    the input level before the span, fitted only for an integrating structure off rest);
    the fit's own error over its ``n_fit`` samples (``mse_fit``), their effective sample
    size and variance factor (:func:`pipeline.uncertainty.variance_factor`); the
    estimated parameters (the model's and the linear nuisances); the parameters'
    standard errors; the search's residual evaluations and starts; how the intervals were
    made; and the ``folds`` of a cross-validated fit over several events.
    ``covariance`` is the one the intervals are made of; ``covariance_fit`` the fit's own
    (from its residuals alone) where the held-out residuals widened it, else None;
    ``sensitivity`` (:class:`RowSensitivity`) is transient, never in results.
    """

    state: StateTreatment
    y0: float
    u0: float
    mse_fit: float
    n_fit: int
    n_eff: float
    variance_factor: float
    n_params: int
    std: dict[str, float]
    nfev: int
    runs: int
    interval_method: str
    carried_from: int | None = None
    folds: tuple[Fold, ...] = ()
    covariance: ParameterCovariance | None = None
    covariance_fit: ParameterCovariance | None = None
    sensitivity: RowSensitivity | None = field(default=None, compare=False, repr=False)

    @property
    def state_text(self) -> str:
        """The state in words: "rest", "estimated", "steady", "carried from event 2"."""
        return f"carried from event {self.carried_from}" if self.state == "carried" \
            else self.state

    @property
    def at_rest(self) -> bool:
        """Whether the fit assumed the plant at rest before its event."""
        return self.state == "rest"

    @property
    def sse(self) -> float:
        """The fit's sum of squared errors."""
        return self.mse_fit * self.n_fit

    def as_diagnostics(self, events: tuple[int, ...] = ()) -> dict:
        """The summary as results.json has always carried it in a fit's ``diagnostics``
        (``events``: a fit over several events lists them there too)."""
        out = {"initial_state": self.state_text, "y0": self.y0, "u0": self.u0,
               "mse_fit": self.mse_fit, "n_fit": self.n_fit, "n_eff": self.n_eff,
               "variance_factor": self.variance_factor, "n_params": self.n_params,
               "std": dict(self.std), "nfev": self.nfev, "runs": self.runs,
               "interval_method": self.interval_method}
        if events:
            out["events"] = list(events)
        if self.folds:
            out["folds"] = [{"events": list(f.events), "params": dict(f.params), "u0": f.u0,
                             "mse": f.mse, "refit": f.refit} for f in self.folds]
        return out


@dataclass(frozen=True)
class Fit:
    """One method on one event: ``status`` and, when ok, the model with its metrics.

    ``ci95`` maps parameter names to 95 % intervals (refined models); ``verdict`` and
    ``flags`` are set by grading (None / empty until then); ``diagnostics`` are the points
    a graphical method read (t63, peaks, areas ...), in absolute record time;
    ``refinement`` is a least-squares refinement's summary (None for a reading).
    ``events`` are all identification events of a model fitted over several of them
    (``event`` is the first); empty for a model of one event.
    """

    method: str
    event: int
    status: FitStatus
    reason: str | None = None
    model: ProcessModel | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    verdict: Verdict | None = None
    flags: tuple[Flag, ...] = ()
    events: tuple[int, ...] = ()
    refinement: RefinementSummary | None = None
    #: wall time of the method and its validation on this event, s (the JUnit testcase's
    #: time; not in results.json, which stays the same from run to run)
    seconds: float | None = field(default=None, compare=False)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def is_refined(self) -> bool:
        """Whether this fit is a least-squares refinement (fitted to all its
        identification data, with intervals and a summary)."""
        return self.refinement is not None

    @property
    def n_params(self) -> int:
        """Estimated parameters: a refinement's own count (the model's and the linear
        nuisances: offset, initial state, input balance), else the model's and the
        offset."""
        if self.refinement is not None:
            return self.refinement.n_params
        return len(self.model.spec.params) + 1 if self.model is not None else 0

    @property
    def balance_point(self) -> float | None:
        """The input balance point an integrating refinement fitted (its ``u0``); None
        for any other fit."""
        if self.model is None or not self.model.integrating or self.refinement is None:
            return None
        return self.refinement.u0
