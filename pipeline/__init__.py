"""pipeline: batch system identification from step and impulse tests.

Data conventions (written down once, used everywhere):

- time in seconds; ``t``, ``u``, ``y`` are float64 1-D numpy arrays, ``t`` strictly increasing;
- models work in deviation variables from the operating point ``(u0, y0)``;
- parameter and structure names come from one table each, :data:`PARAMETERS` and
  :data:`STRUCTURES` (``K`` gain, ``T``, ``T1``, ``T2`` time constants, ``n`` order of an
  equal-lag model, ``zeta`` damping, ``wn`` natural frequency in rad/s, ``delay`` dead
  time in s). There is no second spelling.

The public API (everything in ``__all__``) is imported on first use, so ``import
pipeline`` and the command line start fast::

    import pipeline

    result = pipeline.identify(t, u, y)          # numpy arrays -> RecordResult
    fit = result.recommended                       # fit.model.params, fit.verdict
    record = pipeline.load("log.csv", input="u", output="y", time="t")
    result = pipeline.analyse(record)
"""

from importlib import import_module

from .version import __version__

#: public name -> module that defines it
_API = {
    "load": "api", "identify": "api",
    "analyse": "analysis", "AnalysisOptions": "analysis",
    "run_config": "run", "identify_file": "run",
    "Record": "record", "make_record": "record",
    "segment": "segmentation", "event_data": "segmentation", "SegmentOptions": "segmentation",
    "ProcessModel": "models", "STRUCTURES": "models", "PARAMETERS": "models",
    "simulate": "simulation",
    "identify_event": "api", "REGISTRY": "methods",
    "RecordResult": "results", "RunResult": "results", "load_results": "gate",
    "UserError": "errors", "ExitCode": "errors",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        return getattr(import_module(f".{_API[name]}", __name__), name)
    raise AttributeError(f"module 'pipeline' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
