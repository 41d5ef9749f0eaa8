"""Tuning: controller settings from the recommended model, checked over its uncertainty.

- :mod:`.reduction` - the model as the first- or second-order (or integrating) model with
  an effective dead time that a rule reads (Skogestad's half rule);
- :mod:`.rules` - SIMC, improved SIMC, lambda/IMC and AMIGO (P, PI, PID);
- :mod:`.controller` - the settings in the ideal, parallel and series forms;
- :mod:`.plant` - a model's frequency response with its exact dead time (batches too);
- :mod:`.margins` - Ms, gain, phase and delay margins, Nyquist stability, exact delay;
- :mod:`.robust` - the worst case over the model's 95 % intervals;
- :mod:`.loop` - the tuned loop simulated: setpoint and load steps, actuator limits,
  back-calculation anti-windup;
- :mod:`.tuner` - all of it for one model: :func:`tune` -> :class:`Tuning` with a verdict;
- :mod:`.overshoot` - PI settings without a model, from one closed-loop setpoint step
  under P control (the setpoint overshoot method);
- :mod:`.running` - the running controller's settings read off its log (r, y, u);
- :mod:`.doc` - a record's tuning (:class:`RecordTuning`) as results.json carries it.
"""

from ..schema import THROUGH_LOOP
from .controller import CONTROLLER_KINDS, Controller, ControllerKind
from .doc import (
    UNTRUSTED_FLAGS,
    RecordTuning,
    controller_gain_unit,
    model_trust,
    running_loop_doc,
    through_loop_trust,
    tuning_doc,
)
from .log_loop import (
    LoopReading,
    SetpointStep,
    read_loop,
    setpoint_steps,
    with_plant,
)
from .loop import LoopResponse, Pid, StepMetrics, simulate_loop
from .margins import Margins, loop_margins, sensitivity_peaks
from .overshoot import OvershootTest, read_setpoint_step, setpoint_overshoot_pi
from .reduction import Reduced, reduce, reduce_lags
from .robust import WorstCase, parameter_sets, worst_case
from .rules import RULE_NAMES, TAU_C_FACTORS, KindChoice, RuleName, RuleSettings, tune_rule
from .running import RunningController, identify_controller
from .tuner import (
    FRAGILE_MS,
    MS_TARGET,
    TUNING_VERDICTS,
    ControllerForm,
    TimeUnit,
    Tuning,
    TuningOptions,
    TuningVerdict,
    nominal_margins,
    tune,
)

__all__ = ["CONTROLLER_KINDS", "FRAGILE_MS", "MS_TARGET", "RULE_NAMES", "TAU_C_FACTORS",
           "THROUGH_LOOP", "TUNING_VERDICTS", "UNTRUSTED_FLAGS", "Controller",
           "ControllerForm", "ControllerKind", "KindChoice", "LoopReading",
           "LoopResponse", "Margins", "OvershootTest", "Pid", "RecordTuning", "Reduced",
           "RuleName", "RuleSettings", "RunningController", "SetpointStep",
           "StepMetrics", "TimeUnit", "Tuning", "TuningOptions", "TuningVerdict",
           "WorstCase", "controller_gain_unit", "identify_controller", "loop_margins",
           "model_trust", "nominal_margins", "parameter_sets", "read_loop",
           "read_setpoint_step", "reduce", "reduce_lags", "running_loop_doc",
           "sensitivity_peaks", "setpoint_overshoot_pi", "setpoint_steps",
           "simulate_loop", "through_loop_trust", "tune", "tune_rule", "tuning_doc",
           "with_plant", "worst_case"]
