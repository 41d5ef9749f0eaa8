"""Orchestration of one config: resolve records -> load -> segment -> identify -> validate.

:func:`process_record` is the per-record job the batch layer ships to processes or a Dask
cluster: it takes a picklable :class:`RecordSpec` and the :class:`RunConfig` and never
raises for a bad record; the failure travels in the result.
"""

from __future__ import annotations

import glob
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

from . import __version__
from .config import DataConfig, RunConfig
from .errors import UserError
from .events import Event, EventData
from .fit import Fit
from .io import SUFFIXES, load_record
from .io.options import check_file
from .methods import REGISTRY, identify
from .record import Record
from .segment import SegmentOptions, segment
from .validate import score

#: An event window with fewer samples after t0 gives no model (never a silent bad one).
MIN_WINDOW_SAMPLES = 10


@dataclass(frozen=True)
class RecordSpec:
    """One record to process: a file (``path``) or a registry dataset (``dataset``)."""

    name: str
    path: str
    dataset: str | None = None


@dataclass(frozen=True)
class RecordResult:
    spec: RecordSpec
    record: Record | None = None
    events: list[Event] = field(default_factory=list)
    roles: dict[int, str] = field(default_factory=dict)
    fits: list[Fit] = field(default_factory=list)
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    def ranking(self, event: int | None = None) -> list[Fit]:
        """ok fits ranked by validation MSE (ISE when there is no validation data)."""
        fits = [f for f in self.fits if f.ok and (event is None or f.event == event)]
        return sorted(fits, key=rank_key)

    @property
    def best(self) -> Fit | None:
        ident = [i for i, r in sorted(self.roles.items()) if r == "identification"]
        ranked = self.ranking(ident[0] if ident else None)
        return ranked[0] if ranked else None

    def to_dict(self) -> dict:
        """The results.json form of this record (DESIGN.md "Results contract")."""
        rec = self.record
        best = self.best
        return {
            "name": self.spec.name,
            "source": rec.source if rec else self.spec.path,
            "status": "ok" if self.ok else "failed",
            "error": self.error,
            "n_samples": rec.n_samples if rec else 0,
            "sample_time": rec.sample_time if rec else None,
            "units": rec.units if rec else {},
            "notes": list(rec.notes) if rec else [],
            "events": [{**e.to_dict(), "role": self.roles.get(e.index, "unused")}
                       for e in self.events],
            "fits": [f.to_dict() for f in self.fits],
            "best": {"method": best.method, "event": best.event} if best else None,
            "errors": [self.error] if self.error else [],
        }


def rank_key(f: Fit) -> tuple[float, float]:
    v = f.metrics.get("mse_validation", math.nan)
    i = f.metrics.get("ise", math.nan)
    primary = v if math.isfinite(v) else math.inf
    return (primary, i if math.isfinite(i) else math.inf)


# -- resolving what to process -----------------------------------------------------------

def resolve_specs(cfg: RunConfig) -> list[RecordSpec]:
    """The records a config names; a path that matches nothing, or a ``data:`` key that
    does not apply to a file's format, is a :class:`UserError`."""
    d = cfg.data
    if d.dataset:
        from .datasets import fetch

        return [RecordSpec(name=d.dataset, path=str(fetch(d.dataset)), dataset=d.dataset)]
    patterns = [d.path] if d.path else list(d.paths or [])
    base = Path(cfg.base_dir)
    files: list[Path] = []
    for pat in patterns:
        p = Path(os.path.normpath(pat if Path(pat).is_absolute() else base / pat))
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.suffix.lower() in SUFFIXES)
        elif any(ch in pat for ch in "*?["):
            found = sorted(Path(f) for f in glob.glob(str(p), recursive=True)
                           if Path(f).is_file() and Path(f).suffix.lower() in SUFFIXES)
        else:
            found = [p]
        if not found:
            raise UserError(f"{cfg.source}: key 'data.path': {pat!r} matches no file")
        files.extend(found)
    if len(files) == 1 and not files[0].is_file():
        raise UserError(f"{files[0]}: file not found")
    for f in files:
        check_file(d, f, cfg.source)  # a key of another format: the config is wrong
    names = _unique_names(files)
    return [RecordSpec(name=n, path=str(f)) for n, f in zip(names, files, strict=True)]


def _unique_names(files: list[Path]) -> list[str]:
    """File stems, or paths relative to the files' common folder where stems repeat, with
    a counter where even those repeat (the same file listed twice)."""
    stems = [f.stem for f in files]
    if len(set(stems)) == len(stems):
        return stems
    root = Path(os.path.commonpath([str(f.resolve().parent) for f in files]))
    rel = [f.resolve().relative_to(root).as_posix() for f in files]
    bare = [r.rsplit(".", 1)[0] for r in rel]
    distinct = {b: {r for r, b2 in zip(rel, bare, strict=True) if b2 == b} for b in bare}
    names = [b if len(distinct[b]) == 1 else r for r, b in zip(rel, bare, strict=True)]
    seen: dict[str, int] = {}
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}#{seen[n]}")
    return out


def effective_data(cfg: RunConfig, spec: RecordSpec) -> DataConfig:
    """The data section for one record; a dataset's registry entry fills what is unset."""
    d = cfg.data
    if not spec.dataset:
        return d
    from .datasets import get

    ds = get(spec.dataset)
    fill = {"format": ds.format, "columns": ds.columns, "input": ds.input, "output": ds.output,
            "time": ds.time, "units": ds.units or None, "initial_input": ds.initial_input}
    return d.model_copy(update={k: v for k, v in fill.items() if getattr(d, k) is None})


def segment_options(cfg: RunConfig) -> SegmentOptions:
    s = cfg.segmentation
    return SegmentOptions(min_step=s.min_step, rel_min_step=s.rel_min_step,
                          tail_fraction=s.tail_fraction, head_samples=s.head_samples,
                          pulse_fraction=s.pulse_fraction,
                          settle_time_constants=s.settle_time_constants,
                          settle_drift=s.settle_drift)


# -- the analysis ------------------------------------------------------------------------

def analyse(record: Record, *, events_for_identification: list[int] | str = (0,),
            methods: list[str] | None = None, options: SegmentOptions | None = None,
            spec: RecordSpec | None = None) -> RecordResult:
    """Segment, identify on the chosen events, validate on the others (pure)."""
    spec = spec or RecordSpec(name=record.name, path=record.source)
    events = segment(record, options)
    if not events:
        return RecordResult(spec, record, error=f"{record.source}: no step or impulse event "
                            f"found in the input {record.input_name!r}")
    ident = (list(range(len(events))) if events_for_identification == "all"
             else sorted(set(events_for_identification)))
    missing = [i for i in ident if not 0 <= i < len(events)]
    if not ident:
        return RecordResult(spec, record, events, error=(
            f"{record.source}: no identification event was chosen"))
    if missing:
        return RecordResult(spec, record, events, error=(
            f"{record.source}: identification event {missing[0]} does not exist; the record "
            f"has {len(events)} event(s) (0..{len(events) - 1})"))
    validation = [e.index for e in events if e.index not in ident]
    roles = {e.index: ("identification" if e.index in ident else "validation") for e in events}
    method_ids = list(REGISTRY) if methods is None else list(methods)
    fits: list[Fit] = []
    for i in ident:
        ev = events[i]
        data = EventData.from_event(record, ev)
        short = ev.i_end - ev.i_start < MIN_WINDOW_SAMPLES
        for mid in method_ids:
            if REGISTRY[mid].event != ev.kind and methods is None:
                continue  # all methods: only those for this kind of event are listed
            if short:
                fits.append(Fit(mid, i, "not_applicable", f"window too short: "
                                f"{ev.i_end - ev.i_start} samples after t0, at least "
                                f"{MIN_WINDOW_SAMPLES} are needed"))
                continue
            fit = identify(data, mid)
            if fit.ok:
                fit = replace(fit, metrics=score(fit.model, record, events, ev, validation))
            fits.append(fit)
    return RecordResult(spec, record, events, roles, fits)


def process_record(spec: RecordSpec, cfg: RunConfig) -> RecordResult:
    """Load and analyse one record; a bad record comes back with ``error`` set.

    ``RecordResult.to_dict()`` is the record's results.json entry.
    """
    try:
        data = effective_data(cfg, spec)
        record = load_record(Path(spec.path), data, name=spec.name)
        return analyse(record, events_for_identification=cfg.identification.events,
                       methods=cfg.method_ids(), options=segment_options(cfg), spec=spec)
    except UserError as exc:
        return RecordResult(spec, error=exc.message)


def results_document(results: list[RecordResult], cfg_source: str, created: str) -> dict:
    """The whole results.json object."""
    return finite_or_none({
        "pipeline_version": __version__,
        "config": cfg_source,
        "created": created,
        "records": [r.to_dict() for r in results],
    })


def finite_or_none(obj):
    """NaN and infinities become ``null``: results.json is strict JSON."""
    if isinstance(obj, dict):
        return {k: finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_or_none(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj
