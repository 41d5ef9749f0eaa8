"""What an analysis returns, and the results.json text: made and parsed in one place.

:class:`RecordResult` is one record's outcome in memory (the record's arrays, its events,
every fit, the per-step consistency, the recommendation); :class:`RunResult` is a run's
records and where they came from. Both turn into the typed document of
:mod:`pipeline.schema` (:meth:`RunResult.to_doc`), whose text :func:`results_json` makes
and :func:`parse_results` validates (any readable schema version; the files are written
by :mod:`pipeline.report` and read by :func:`pipeline.gate.load_results`). The report,
the regression gate, the history and the JUnit writer all take that document. Pure: no
file is touched here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pydantic import ValidationError

from .errors import UserError
from .events import Event
from .fit import Fit, Flag
from .record import Record
from .schema import (
    READABLE_VERSIONS,
    ConsistencyDoc,
    EstimateDoc,
    EventDoc,
    FitDoc,
    FlagDoc,
    MetricsDoc,
    RecommendedDoc,
    RecordDoc,
    ResultsDoc,
    Role,
    StaticMapDoc,
    TransferFunctionDoc,
    fit_label,
)
from .tuning import LoopReading, RecordTuning, running_loop_doc, tuning_doc
from .version import __version__


@dataclass(frozen=True)
class EventEstimate:
    """One step identified on its own: gain and dominant time constant with 95 %
    intervals, where (input/output levels before and after) and when (t0)."""

    index: int
    t0: float
    u0: float
    u1: float
    y0: float
    y_inf: float  # the asymptote: y0 + K (u1 - u0)
    K: float
    K_ci: tuple[float, float]
    T: float
    T_ci: tuple[float, float]
    state: str = ""  # how the initial state was treated (rest, carried, estimated)
    K_se: float = math.nan  # the gain's standard error (the tests use it, not the interval)

    @property
    def up(self) -> bool:
        return self.u1 > self.u0


@dataclass(frozen=True)
class StaticMap:
    """Settled output against input level: the levels and the two fits."""

    u: tuple[float, ...]
    y: tuple[float, ...]
    line: tuple[float, float]  # (a, b): y = a + b u
    quadratic: tuple[float, float, float]  # (a, b, c): y = a + b u + c u^2
    rms_line: float
    rms_quadratic: float
    nonlinear: bool
    p_curvature: float


@dataclass(frozen=True)
class Consistency:
    """Each step on its own, and what they say together."""

    estimates: tuple[EventEstimate, ...]
    static_map: StaticMap | None


@dataclass(frozen=True)
class Recommendation:
    """The record's recommended model: which fit, and why (:func:`pipeline.grading.recommend`;
    grading adds the verdict). ``events``: all events of a model fitted over
    several (empty for a one-event fit)."""

    method: str
    event: int
    reason: str = ""
    events: tuple[int, ...] = ()


@dataclass(frozen=True)
class RecordResult:
    """One record's outcome. ``error`` is set when it could not be analysed; ``roles``
    maps event index -> "identification" | "validation" | "unused"."""

    name: str
    source: str
    record: Record | None = None
    events: list[Event] = field(default_factory=list)
    roles: dict[int, Role] = field(default_factory=dict)
    fits: list[Fit] = field(default_factory=list)
    error: str | None = None
    recommendation: Recommendation | None = None
    flags: tuple[Flag, ...] = ()  # findings about the whole log (grading)
    consistency: Consistency | None = None  # each step on its own (pipeline.grading)
    tuning: RecordTuning | None = None  # the controller tuned from the recommended model
    loop: LoopReading | None = None  # a closed-loop log's controller, read with its setpoint

    @property
    def ok(self) -> bool:
        return self.error is None

    @property
    def identification_events(self) -> list[int]:
        return sorted(i for i, r in self.roles.items() if r == "identification")

    @property
    def validation_events(self) -> list[int]:
        return sorted(i for i, r in self.roles.items() if r == "validation")

    def fit(self, method: str, event: int, events: tuple[int, ...] | None = None
            ) -> Fit | None:
        """The fit of ``method`` on ``event`` (``events``: of a multi-event fit; None:
        the first match)."""
        return next((f for f in self.fits if f.method == method and f.event == event and (
            events is None or tuple(f.events) == tuple(events))), None)

    @property
    def recommended(self) -> Fit | None:
        """The fit the recommendation points at."""
        r = self.recommendation
        return self.fit(r.method, r.event, r.events) if r else None

    def to_doc(self) -> RecordDoc:
        """This record's results.json entry."""
        rec = self.record
        median, jitter = rec.sampling() if rec else (None, None)
        return RecordDoc(
            name=self.name, source=rec.source if rec else self.source,
            status="ok" if self.ok else "failed", error=self.error,
            n_samples=rec.n_samples if rec else 0,
            sample_time=rec.sample_time if rec else None,
            median_interval=median, interval_jitter=jitter,
            units=dict(rec.units) if rec else {}, start=rec.start if rec else None,
            notes=list(rec.notes) if rec else [],
            events=[event_doc(e, self.roles.get(e.index, "unused")) for e in self.events],
            fits=[fit_doc(f) for f in self.fits],
            recommended=self._recommended_doc(),
            flags=[flag_doc(x) for x in self.flags],
            consistency=consistency_doc(self.consistency),
            tuning=tuning_doc(self.tuning),
            running_loop=running_loop_doc(self.loop),
            errors=[self.error] if self.error else [],
        )

    def _recommended_doc(self) -> RecommendedDoc | None:
        f = self.recommended
        if f is None or f.model is None:
            return None
        return RecommendedDoc(
            method=f.method, event=f.event, events=list(f.events),
            structure=f.model.structure,
            params=_params(f.model.params), ci95=_ci(f.ci95), verdict=f.verdict,
            flags=[flag_doc(x) for x in f.flags], reason=self.recommendation.reason)


@dataclass(frozen=True)
class RunResult:
    """A run: its records and where they came from (``config``: the config file, or
    what ``identify`` was called on)."""

    records: list[RecordResult]
    config: str = ""
    created: str = ""

    @property
    def failures(self) -> list[str]:
        return [r.error for r in self.records if r.error]

    def to_doc(self) -> ResultsDoc:
        return ResultsDoc(pipeline_version=__version__, config=self.config,
                          created=self.created, records=[r.to_doc() for r in self.records])


# -- runtime objects -> document ---------------------------------------------------------

def event_doc(e: Event, role: str) -> EventDoc:
    impulse = e.kind == "impulse"
    return EventDoc(
        index=e.index, kind=e.kind, t0=e.t0, t_end=e.t_end, i_start=e.i_start,
        i_end=e.i_end, u0=e.u0, u_ss=e.u_ss, y0=_finite(e.y0), y_ss=_finite(e.y_ss),
        area=e.area if impulse else None, duration=e.duration if impulse else None,
        settled=e.settled, noise=_finite(e.noise), response=e.response,
        slope=_finite(e.slope), drift=_finite(e.drift), role=role)


def consistency_doc(c: Consistency | None) -> ConsistencyDoc | None:
    if c is None:
        return None
    m = c.static_map
    return ConsistencyDoc(
        estimates=[EstimateDoc(event=e.index, t0=e.t0, u0=e.u0, u1=e.u1, y0=e.y0,
                               y_inf=e.y_inf, K=e.K, K_ci95=_pair(e.K_ci), T=e.T,
                               T_ci95=_pair(e.T_ci), state=e.state) for e in c.estimates],
        static_map=None if m is None else StaticMapDoc(
            u=list(m.u), y=list(m.y), line=list(m.line), quadratic=list(m.quadratic),
            rms_line=m.rms_line, rms_quadratic=m.rms_quadratic, nonlinear=m.nonlinear,
            p_curvature=m.p_curvature))


def _pair(ci) -> tuple[float | None, float | None]:
    return (_finite(ci[0]), _finite(ci[1]))


def flag_doc(f: Flag) -> FlagDoc:
    return FlagDoc(code=f.code, message=f.message, severity=f.severity,
                   values={k: _plain(v) for k, v in f.values.items()})


def fit_doc(f: Fit) -> FitDoc:
    m = f.model
    tf = None
    if m is not None:
        nd = m.num_den()
        tf = TransferFunctionDoc(num=nd[0] if nd else None, den=nd[1] if nd else None,
                                 delay=m.delay, text=m.text())
    metrics = MetricsDoc(**{k: _finite(v) for k, v in f.metrics.items()
                            if k in MetricsDoc.model_fields})
    return FitDoc(
        method=f.method, event=f.event, events=list(f.events), status=f.status,
        reason=f.reason,
        structure=m.structure if m else None, params=_params(m.params) if m else None,
        ci95=_ci(f.ci95), transfer_function=tf, metrics=metrics, verdict=f.verdict,
        flags=[flag_doc(x) for x in f.flags], diagnostics=_plain(diagnostics_of(f)))


def diagnostics_of(f: Fit) -> dict:
    """A fit's results.json ``diagnostics``: a reading's points, a refinement's summary
    (:meth:`pipeline.fit.RefinementSummary.as_diagnostics`, the shape of schema 2)."""
    if f.refinement is None:
        return f.diagnostics
    return {**f.diagnostics, **f.refinement.as_diagnostics(f.events)}


def _params(p: dict) -> dict[str, float]:
    return {k: float(v) for k, v in p.items()}


#: An interval bound beyond this magnitude means "unbounded" (null in results.json).
UNBOUNDED = 1e100


def _ci(ci: dict) -> dict[str, tuple[float | None, float | None]]:
    return {k: (_bound(lo), _bound(hi)) for k, (lo, hi) in ci.items()}


def _bound(v) -> float | None:
    v = _finite(v)
    return None if v is None or abs(v) > UNBOUNDED else v


def _finite(v) -> float | None:
    return float(v) if v is not None and math.isfinite(float(v)) else None


def _plain(obj):
    """numpy scalars and arrays to JSON-friendly Python values; NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


# -- the file ----------------------------------------------------------------------------

def fit_times(records: list[RecordResult]) -> dict[tuple[str, int, str], float]:
    """Each fit's measured wall time by ``(record, event, label)`` (the JUnit testcases'
    times; results.json keeps none, so two runs of the same data write the same file)."""
    return {(r.name, f.event, fit_label(f.method, f.event, list(f.events))): f.seconds
            for r in records for f in r.fits if f.seconds is not None}


def results_json(doc: ResultsDoc) -> str:
    """The results.json text of ``doc`` (strict JSON: NaN is null)."""
    return doc.model_dump_json(indent=1) + "\n"


def parse_results(text: str, where: str = "<results>") -> ResultsDoc:
    """Validate results.json text; a problem is a one-line :class:`UserError`."""
    import json

    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise UserError(f"{where}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except RecursionError:  # json gives up on deeply nested arrays: not our shape
        raise UserError(f"{where}: not a results.json file (nested too deeply); expected an "
                        "object with a 'records' list") from None
    if not isinstance(raw, dict) or not isinstance(raw.get("records"), list):
        raise UserError(f"{where}: not a results.json file; expected an object with a "
                        "'records' list")
    version = str(raw.get("schema_version", "1"))
    if version not in READABLE_VERSIONS:
        raise UserError(f"{where}: schema_version {version!r} is not readable by pipeline "
                        f"{__version__}; expected one of {', '.join(READABLE_VERSIONS)}")
    raw["schema_version"] = version
    try:
        return ResultsDoc.model_validate(raw)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"])
        raise UserError(f"{where}: not a valid results.json ({loc}: {err['msg']})") from None


def as_doc(doc: ResultsDoc | dict) -> ResultsDoc:
    """A results document; a plain dict (e.g. built by hand in a test) is validated."""
    if isinstance(doc, ResultsDoc):
        return doc
    import json

    return parse_results(json.dumps(doc))
