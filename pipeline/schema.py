"""The results contract: typed models of results.json (DESIGN.md "Results contract").

One pydantic model per object of the document. The JSON Schema that ``pipeline schema``
prints is generated from them (:func:`json_schema`) and shipped in the package
(``pipeline/data/results.schema.json``, checked against the models by a test). The
report, the regression gate, the history and the JUnit writer read these objects, never
string keys of a dict.

Versions: ``schema_version`` "4" is this layout: a record carries ``running_loop`` (a
closed-loop log read with its setpoint: the running controller, the setpoint steps, the
plant fitted through the loop; null for an open-loop test). Version 3: a flag's severity
may be ``info`` (it does not change the verdict), and ``best`` is written as null (the
recommended model is the one answer); a record may carry ``tuning`` (the controller
tuned from the recommended model). Versions 3, 2 and 1 (pipeline 0.1, no
``schema_version`` key) are read too: their objects are a subset of version 4.
"""

from __future__ import annotations

import json
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

SCHEMA_VERSION = "4"
READABLE_VERSIONS = ("1", "2", "3", "4")
#: The source a closed-loop log's plant fitted through its loop is named by, where a fit's
#: method would be (``tuning.method``, the history's ``method``).
THROUGH_LOOP = "plant_through_loop"

# The vocabularies the results and the runtime types share (pipeline.fit, pipeline.events).
#: A method's outcome on an event: a model, no model with the reason, or a method bug.
FitStatus = Literal["ok", "not_applicable", "failed"]
#: Verdict of a fit that has a model (DESIGN.md "Validation and grading").
Verdict = Literal["ok", "warning", "unreliable"]
#: What a flag means for its model: unusable, limited, or information (no limit).
Severity = Literal["info", "warning", "unreliable"]
EventKind = Literal["step", "impulse"]
#: How the output responds to an event (segmentation).
Response = Literal["settling", "ramp", "level_shift"]
Role = Literal["identification", "validation", "unused"]


def fit_label(method: str, event: int, events: list[int]) -> str:
    """A fit's name within its record: the method, with the events of a joint fit
    (``lsq_first_order[0,2]``), since a joint fit and the first event's own fit of the same
    method are different fits."""
    if not events or list(events) == [event]:
        return method
    return f"{method}[{','.join(str(e) for e in events)}]"


class _Doc(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, ser_json_inf_nan="null")


class FlagDoc(_Doc):
    """One reason behind a verdict: a stable code, plain words and the numbers."""

    code: str
    message: str
    values: dict[str, float | str | None] = Field(default_factory=dict)
    severity: Severity = "warning"


class TransferFunctionDoc(_Doc):
    """The rational part in descending powers of s (null for a non-integer order), the
    dead time beside it, and a readable text."""

    num: list[float] | None = None
    den: list[float] | None = None
    delay: float = 0.0
    text: str = ""


class MetricsDoc(_Doc):
    """Fit criteria (null where there is no data): ``ise`` over the identification event
    (seed 002 eq. 25), ``mse_identification`` over the same samples (both from rest at the
    event's operating point), ``mse_validation`` (seed 001's J) and ``fit_percent``
    (MATLAB's NRMSE fit) over the validation events (simulated continuously, the offset
    estimated on a warm-up); ``mse_cross_validation`` the held-out MSE when every event
    identifies (leave-one-event-out for a model of all events, the other events for a model
    of one; beyond ten events ten folds, and ten events spread over the record); ``aic``
    Akaike's criterion on the identification event (one effective sample size per event,
    so comparable between the models of an event)."""

    ise: float | None = None
    mse_identification: float | None = None
    mse_validation: float | None = None
    fit_percent: float | None = None
    mse_cross_validation: float | None = None
    aic: float | None = None


class FitDoc(_Doc):
    """One method on one event (``events``: all identification events of a multi-event
    fit; empty means ``[event]``)."""

    method: str
    event: int
    events: list[int] = Field(default_factory=list)
    status: FitStatus
    reason: str | None = None
    structure: str | None = None
    params: dict[str, float] | None = None
    ci95: dict[str, tuple[float | None, float | None]] = Field(default_factory=dict)
    transfer_function: TransferFunctionDoc | None = None
    metrics: MetricsDoc = Field(default_factory=MetricsDoc)
    verdict: Verdict | None = None
    flags: list[FlagDoc] = Field(default_factory=list)
    diagnostics: dict[str, Any] = Field(default_factory=dict)

    @property
    def label(self) -> str:
        return fit_label(self.method, self.event, self.events)


class EventDoc(_Doc):
    """One step or impulse found by segmentation, and the role it played. ``response``:
    whether the output settles, ramps (an integrating process after a step; ``slope`` is
    the final ramp's, output units per second) or moves to a new level and stays (an
    integrating process after a pulse); ``drift``: the output's slope before ``t0``."""

    index: int
    kind: EventKind
    t0: float
    t_end: float
    i_start: int
    i_end: int
    u0: float
    u_ss: float
    y0: float | None
    y_ss: float | None
    area: float | None = None
    duration: float | None = None
    settled: bool
    noise: float | None = None
    response: Response = "settling"
    slope: float | None = None
    drift: float | None = None
    role: Role = "unused"


class BestDoc(_Doc):
    """Written up to pipeline 0.2 (schema 2): the fit of the first identification event with
    the lowest validation MSE. Read, never written since: ``recommended`` is the one answer
    (an ISE- or MSE-ranked "best" beside it named another model)."""

    method: str
    event: int
    events: list[int] = Field(default_factory=list)

    @property
    def label(self) -> str:
        return fit_label(self.method, self.event, self.events)


class RecommendedDoc(_Doc):
    """The model to use for the record, with why it was chosen and whether to trust it
    (``events``: all events of a model fitted over several; empty means ``[event]``)."""

    method: str
    event: int
    events: list[int] = Field(default_factory=list)
    structure: str
    params: dict[str, float]
    ci95: dict[str, tuple[float | None, float | None]] = Field(default_factory=dict)
    verdict: Verdict | None = None
    flags: list[FlagDoc] = Field(default_factory=list)
    reason: str = ""

    @property
    def label(self) -> str:
        return fit_label(self.method, self.event, self.events)


class EstimateDoc(_Doc):
    """One step identified on its own: its gain at the recommended dynamics and its own
    dominant time constant, with 95 % intervals, its input levels and the output's
    asymptotes (:mod:`pipeline.grading.consistency`)."""

    event: int
    t0: float
    u0: float
    u1: float
    y0: float
    y_inf: float
    K: float
    K_ci95: tuple[float | None, float | None]
    T: float
    T_ci95: tuple[float | None, float | None]
    state: str = ""


class StaticMapDoc(_Doc):
    """Settled output against input level: the points, a line ``[a, b]`` (y = a + b u) and a
    quadratic ``[a, b, c]``; ``nonlinear`` when the quadratic is clearly better."""

    u: list[float]
    y: list[float]
    line: list[float]
    quadratic: list[float]
    rms_line: float
    rms_quadratic: float
    nonlinear: bool
    p_curvature: float


class ConsistencyDoc(_Doc):
    """Each step on its own, and the static map they trace."""

    estimates: list[EstimateDoc] = Field(default_factory=list)
    static_map: StaticMapDoc | None = None


class ControllerDoc(_Doc):
    """Controller settings in the ideal (ISA) form, seconds: ``Kc`` signed (input unit per
    output unit, the sign of the process gain), ``Ti`` null without integral action, ``Tf``
    the derivative filter's time constant."""

    kind: Literal["P", "PI", "PID"]
    Kc: float
    Ti: float | None = None
    Td: float = 0.0
    Tf: float = 0.0


class AlternativeDoc(_Doc):
    """Beside settings that are fragile or unstable over the interval: the same rule with
    the fastest ``tau_c`` (s) whose worst-case Ms over the intervals is ``worst_ms``."""

    tau_c: float
    controller: ControllerDoc
    worst_ms: float


class MarginsDoc(_Doc):
    """The loop's robustness with the exact dead time; null means infinite (no crossover)
    or not defined."""

    stable: bool
    ms: float | None = None
    mt: float | None = None
    gain_margin: float | None = None
    phase_margin: float | None = Field(None, description="degrees")
    delay_margin: float | None = Field(None, description="seconds")
    wc: float | None = Field(None, description="gain crossover, rad/s")
    w180: float | None = Field(None, description="phase crossover, rad/s")


class WorstCaseDoc(_Doc):
    """The settings on every parameter set inside the model's 95 % intervals."""

    ms: float | None = Field(None, description="null when some set is unstable")
    stable_fraction: float
    n_sets: int
    params: dict[str, float] = Field(default_factory=dict)
    n_corners: int = Field(0, description="how many of the sets are the box's corners")
    unstable_corners: int = 0
    unstable_draws: int = Field(0, description="unstable sets among the covariance draws")


class StepMetricsDoc(_Doc):
    iae: float
    overshoot: float
    peak_deviation: float
    settling_time: float | None = None
    u_peak: float
    saturated: bool


class LoopDoc(_Doc):
    """The tuned loop simulated: a setpoint step, then a load step at the plant input."""

    r_step: float
    d_step: float
    u_limits: tuple[float, float] | None = None
    setpoint: StepMetricsDoc
    load: StepMetricsDoc


class ReducedDoc(_Doc):
    """The model the rule read (Skogestad's half rule): its kind, gain, lags, dead time."""

    kind: str
    K: float
    theta: float
    tau1: float = 0.0
    tau2: float = 0.0
    zeta: float = 1.0
    steps: list[str] = Field(default_factory=list)


TuningVerdictName = Literal["robust", "fragile", "unstable_in_interval", "unchecked"]


class ReplacedDoc(_Doc):
    """The rule's default settings (``tau_c`` not given) that were fragile or unstable
    over the intervals, so the tuning gives the robust choice of ``tau_c`` instead: their
    ``tau_c`` (s), controller, verdict, its reasons and their worst-case Ms (null:
    unstable on some parameter set), and their range over the intervals
    (``controller_ci95``, as the tuning's own): the regression gate compares these."""

    tau_c: float
    controller: ControllerDoc
    verdict: TuningVerdictName
    reasons: list[str] = Field(default_factory=list)
    worst_ms: float | None = None
    controller_ci95: dict[str, tuple[float, float]] = Field(default_factory=dict)


class TuningDoc(_Doc):
    """The controller tuned from the recommended model (``status`` "not_applicable" with the
    ``reason`` when the rule does not apply): the rule and what it read, the settings in
    the ideal form (seconds) and in the requested ``form``/``time_unit`` (magnitudes; the
    ``action`` carries the sign), the margins, the worst case over the intervals, the
    verdict and the simulated loop."""

    status: Literal["ok", "not_applicable"]
    reason: str | None = None
    method: str
    event: int
    events: list[int] = Field(default_factory=list)
    rule: str
    kind: Literal["P", "PI", "PID"] | None = None
    tau_c: float | None = None
    ms_target: float | None = None
    reduced: ReducedDoc | None = None
    controller: ControllerDoc | None = None
    controller_ci95: dict[str, tuple[float, float]] = Field(
        default_factory=dict, description="the ideal-form settings (Kc signed, seconds) the "
        "rule gives on the parameter sets inside the model's 95 % intervals (box corners and "
        "covariance draws), smallest to largest")
    form: Literal["ideal", "parallel", "series"] = "ideal"
    time_unit: Literal["s", "min"] = "s"
    settings: dict[str, float | None] = Field(default_factory=dict)
    action: Literal["reverse", "direct"] | None = None
    gain_unit: str = ""
    percent_gain: float | None = None
    margins: MarginsDoc | None = None
    worst_case: WorstCaseDoc | None = None
    verdict: TuningVerdictName | None = None
    reasons: list[str] = Field(default_factory=list)
    alternative: AlternativeDoc | None = None
    replaced: ReplacedDoc | None = None
    notes: list[str] = Field(default_factory=list)
    response: LoopDoc | None = None
    worst_response: LoopDoc | None = None


class SetpointStepDoc(_Doc):
    """A setpoint step of a closed-loop log (s, the setpoint's unit) and the setpoint
    overshoot method's PI settings from it (a loop under P control), or why none."""

    time: float
    change: float
    overshoot: float | None = Field(None, description="D = (dyp - dyinf) / dyinf")
    peak_time: float | None = Field(None, description="tp, s after the step")
    offset_ratio: float | None = Field(None, description="b = dyinf / dys")
    controller: ControllerDoc | None = None
    reason: str | None = None


class PlantThroughLoopDoc(_Doc):
    """The plant fitted through its closed loop, the running controller known (the
    indirect approach: the loop's response from the setpoint to the measurement)."""

    structure: str
    params: dict[str, float]
    ci95: dict[str, tuple[float | None, float | None]] = Field(default_factory=dict)
    std: dict[str, float] = Field(default_factory=dict)
    rms: float | None = Field(None, description="RMS of the residuals (output unit)")
    variance_factor: float | None = None


class RunningLoopDoc(_Doc):
    """A closed-loop log read with its setpoint (``data.setpoint``): the running
    controller's settings with their standard errors, or why they could not be read,
    and the setpoint steps."""

    setpoint: str
    controller: ControllerDoc | None = None
    std: dict[str, float] = Field(default_factory=dict)
    bias: float | None = Field(None, description="the controller output's bias u_b")
    residual_share: float | None = Field(None, description="RMS the settings do not "
                                         "explain, over the output's standard deviation")
    converged: bool | None = None
    reason: str | None = None
    setpoint_steps: list[SetpointStepDoc] = Field(default_factory=list)
    plant: PlantThroughLoopDoc | None = None
    plant_reason: str | None = None


class RecordDoc(_Doc):
    """One log: what was loaded, the events found, every fit, and the recommendation;
    ``flags`` are findings about the whole log (they are on every fit too)."""

    name: str
    source: str
    status: Literal["ok", "failed"]
    error: str | None = None
    n_samples: int = 0
    sample_time: float | None = Field(None, description="the grid's interval (s) when it "
                                      "is uniform; null on an irregular grid")
    median_interval: float | None = Field(None, description="the median of the time "
                                          "stamps' intervals (s), uniform grid or not")
    interval_jitter: float | None = Field(None, description="the intervals' standard "
                                          "deviation over their median (0: uniform)")
    units: dict[str, str] = Field(default_factory=dict)
    start: str | None = Field(None, description="the absolute time of the first sample "
                              "(ISO-8601 with offset), when the log has date-times")
    notes: list[str] = Field(default_factory=list)
    events: list[EventDoc] = Field(default_factory=list)
    fits: list[FitDoc] = Field(default_factory=list)
    best: BestDoc | None = None  # read from older documents; always null when written
    recommended: RecommendedDoc | None = None
    flags: list[FlagDoc] = Field(default_factory=list)
    consistency: ConsistencyDoc | None = None
    tuning: TuningDoc | None = None
    running_loop: RunningLoopDoc | None = None
    errors: list[str] = Field(default_factory=list)


class ResultsDoc(_Doc):
    """The whole results.json document."""

    model_config = ConfigDict(title="pipeline results.json")

    schema_version: Literal["1", "2", "3", "4"] = SCHEMA_VERSION
    pipeline_version: str
    config: str = ""
    created: str = ""
    records: list[RecordDoc] = Field(default_factory=list)

    def record(self, name: str) -> RecordDoc | None:
        """The record called ``name``, if any."""
        return next((r for r in self.records if r.name == name), None)


def json_schema() -> dict:
    """The JSON Schema of results.json (draft 2020-12), generated from the models."""
    schema = ResultsDoc.model_json_schema(mode="serialization")
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}


def json_schema_text() -> str:
    """:func:`json_schema` as the text shipped in ``pipeline/data/results.schema.json``."""
    return json.dumps(json_schema(), indent=1, sort_keys=True) + "\n"
