"""Run configuration: YAML read with ``yaml.safe_load`` and validated by pydantic.

Every problem is one :class:`~pipeline.errors.UserError` line naming the file, the key path
(e.g. ``data.inptu``) and what was expected. Relative paths are relative to the config file.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from .errors import UserError
from .files import read_text
from .io import DataConfig, check_section
from .quoting import quoted

#: At most this many values (after YAML aliases are expanded) in a config: a config holds
#: tens of keys and a few thousand file names at most; an alias bomb holds billions.
MAX_VALUES = 100_000


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SegmentationConfig(_Strict):
    min_step: float | None = Field(None, gt=0)
    rel_min_step: float = Field(0.05, gt=0, lt=1)
    tail_fraction: float = Field(0.1, gt=0, le=0.5)
    head_samples: int = Field(2, ge=1)
    pulse_fraction: float = Field(0.1, gt=0, lt=1)
    settle_time_constants: float = Field(4.0, gt=0)
    settle_drift: float = Field(0.01, gt=0, lt=1)


class IdentificationConfig(_Strict):
    """Which events identify (the others validate; ``all``: every event, with
    leave-one-event-out cross-validation, ten folds beyond ten events) and how the
    least-squares refinements run: ``starts`` runs from the best candidate starts,
    ``bootstrap`` block-bootstrap refits for the intervals (0: Jacobian intervals scaled
    by the effective sample size)."""

    events: list[int] | Literal["all"] = Field(default_factory=lambda: [0])
    starts: int = Field(3, ge=1, le=20)
    bootstrap: int = Field(0, ge=0, le=2000)

    def refine_options(self):
        """The :class:`pipeline.refine.RefineOptions` of this section."""
        from .refine import RefineOptions

        return RefineOptions(n_starts=self.starts, bootstrap=self.bootstrap)

    @field_validator("events")
    @classmethod
    def _nonneg(cls, v):
        if isinstance(v, list) and (not v or any(i < 0 for i in v)):
            raise ValueError("expected a non-empty list of event indices >= 0, or 'all'")
        return v


class ReportConfig(_Strict):
    title: str | None = None
    html: bool = True
    markdown: bool = True
    plots: Literal["auto", "full", "summary", "none"] = "auto"


class TuningConfig(_Strict):
    """How to tune a controller from each record's recommended model (``pipeline.tuning``):
    ``rule`` (simc, simc_improved, lambda, amigo), ``kind`` (auto, P, PI, PID), ``tau_c``
    (seconds, ``tight`` = the dead time, ``smooth`` = three times it, or ``robust``: the
    fastest whose worst-case Ms over the model's intervals is at most ``ms_target``),
    the ``form`` and ``time_unit`` the settings are shown in, the instrument spans for a
    gain in %/%, the actuator ``limits`` (input units; default: the range the log saw),
    the controller's ``sample_time`` (s; 0: continuous), ``enabled: false`` to skip."""

    enabled: bool = True
    rule: Literal["simc", "simc_improved", "lambda", "amigo"] = "simc"
    kind: Literal["auto", "P", "PI", "PID"] = "auto"
    tau_c: float | Literal["tight", "smooth", "robust"] | None = None
    ms_target: float = Field(1.7, gt=1.0, le=5.0)
    form: Literal["ideal", "parallel", "series"] = "ideal"
    time_unit: Literal["s", "min"] = "s"
    input_span: float | None = Field(None, gt=0)
    output_span: float | None = Field(None, gt=0)
    limits: tuple[float, float] | None = None
    sample_time: float = Field(0.0, ge=0)
    simulate: bool = True

    @field_validator("tau_c")
    @classmethod
    def _positive(cls, v):
        if isinstance(v, int | float) and not isinstance(v, bool) and v <= 0:
            raise ValueError("expected a positive number of seconds, or tight, smooth, "
                             "robust")
        return v

    @field_validator("limits")
    @classmethod
    def _ordered(cls, v):
        if v is not None and not v[0] < v[1]:
            raise ValueError("expected [low, high] with low < high")
        return v

    def options(self):
        """The :class:`pipeline.tuning.TuningOptions` of this section (None: disabled)."""
        from .tuning import TuningOptions

        if not self.enabled:
            return None
        robust = self.tau_c == "robust"
        return TuningOptions(
            rule=self.rule, kind=self.kind, tau_c=None if robust else self.tau_c,
            ms_target=self.ms_target if robust else None, form=self.form,
            time_unit=self.time_unit, input_span=self.input_span,
            output_span=self.output_span, u_limits=self.limits, simulate=self.simulate,
            sample_time=self.sample_time)


def folder_name(label: str) -> str:
    """The folder a run's ``name`` gives under ``reports/`` when no ``output:`` is set.

    ``name`` is a label (the report title, the JUnit suite), never a path: every run of
    characters other than letters, digits, ``-``, ``_`` and ``.`` becomes one ``_``,
    leading dots and underscores are dropped (no ``..``, no hidden folder), it is cut to
    100 characters, and ``run`` stands for a name with nothing left. A name that had to
    change gets the first 8 hex digits of its SHA-256 (two nightly configs named ``a/b``
    and ``a b`` must not overwrite each other's reports): ``thermal`` -> ``thermal``,
    ``../../../x`` -> ``x-0274b718``, ``Line 2 / oven`` -> ``Line_2_oven-<8 hex>``.
    """
    safe = re.sub(r"[^\w.-]+", "_", label, flags=re.UNICODE).lstrip("._")[:100]
    safe = safe.rstrip("._") or "run"
    if safe == label:
        return safe
    return f"{safe}-{hashlib.sha256(label.encode('utf-8', 'surrogatepass')).hexdigest()[:8]}"


class RunConfig(_Strict):
    name: str = Field("run", description="a label (report title); the default report "
                      "folder is reports/ and this label made safe (folder_name)")
    data: DataConfig
    segmentation: SegmentationConfig = SegmentationConfig()
    identification: IdentificationConfig = IdentificationConfig()
    methods: list[str] | Literal["all"] = "all"
    consistency: bool | None = Field(
        None, description="identify every step on its own and compare them (default: with "
                          "three steps or more)")
    output: str | None = None
    report: ReportConfig = ReportConfig()
    tuning: TuningConfig = TuningConfig()
    base_dir: str = Field(".", exclude=True)
    source: str = Field("<config>", exclude=True)

    @field_validator("methods")
    @classmethod
    def _known_methods(cls, v):
        if v == "all":
            return v
        if not v:
            raise ValueError("expected 'all' or a non-empty list of method ids")
        from .methods import REGISTRY

        unknown = [m for m in v if m not in REGISTRY]
        if unknown:
            from .suggest import did_you_mean

            raise ValueError(
                f"unknown method {unknown[0]!r}{did_you_mean(unknown[0], REGISTRY)}; "
                "expected 'all' or ids from: "
                + ", ".join(REGISTRY)
            )
        return v

    def report_folder(self) -> Path:
        """Where the reports go without ``--out``: ``output:`` (relative to the config
        file), else ``./reports/`` and :func:`folder_name` of ``name`` (never outside it)."""
        if self.output:
            return Path(self.base_dir) / self.output
        return Path("reports") / folder_name(self.name)

    def method_ids(self) -> list[str] | str:
        """``"all"`` or the listed ids (:func:`pipeline.methods.select_methods` decides)."""
        return self.methods if self.methods == "all" else list(self.methods)


class _UniqueKeys(yaml.SafeLoader):
    """``yaml.safe_load`` that refuses a key given twice in one mapping (issue 31: the
    later value won silently, so a second ``methods:`` hid the first)."""

    def construct_mapping(self, node, deep=False):
        seen: dict = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue  # "<<: *base": merged keys may be overridden, as YAML says
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: the base class says so
                break
            if first is not None:  # an alias (*k) of the first key is the same node
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {str(key)[:40]!r} given twice (first at line "
                    f"{first.start_mark.line + 1})", key_node.start_mark)
            seen[key] = key_node
        return super().construct_mapping(node, deep=deep)


def load_config(path: str | Path) -> RunConfig:
    """Read and validate a YAML config file (a key given twice is an error)."""
    path = Path(path)
    text = read_text(path, "config file")
    try:
        raw = yaml.load(text, Loader=_UniqueKeys)  # noqa: S506 (a SafeLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise UserError(f"{path}: {where}not valid YAML ({problem})") from None
    except RecursionError:
        raise UserError(f"{path}: not valid YAML (nested too deeply); expected a config "
                        "of keys, lists and values") from None
    if _expanded_size(raw, MAX_VALUES) > MAX_VALUES:
        raise UserError(f"{path}: its YAML aliases (*name) expand to more than "
                        f"{MAX_VALUES:,} values or refer to themselves; expected a config "
                        "of keys, lists and values")
    if not isinstance(raw, dict):
        raise UserError(f"{path}: expected a mapping of keys (name, data, methods, ...)")
    return config_from_dict(raw, source=str(path), base_dir=str(path.parent))


def config_from_dict(raw: dict, *, source: str = "<config>", base_dir: str = ".") -> RunConfig:
    try:
        cfg = RunConfig.model_validate(raw)
    except ValidationError as exc:
        raise UserError(f"{source}: {_describe(exc)}") from None
    cfg = cfg.model_copy(update={"base_dir": base_dir, "source": source})
    _check_data(cfg, source)
    return cfg


def _describe(exc: ValidationError) -> str:
    rank = {"extra_forbidden": 0, "missing": 1}
    err = min(exc.errors(), key=lambda e: rank.get(e["type"], 2))
    loc = _clean_loc(err["loc"])
    kind = err["type"]
    if kind == "extra_forbidden":
        from .suggest import did_you_mean

        keys = _keys_at(err["loc"][:-1])
        hint = did_you_mean(str(err["loc"][-1]), keys) if keys else ""
        return f"unknown key '{loc}'" + (hint or "; check its spelling") + (
            f" (the keys there: {', '.join(keys)})" if keys and not hint else "")
    if kind == "missing":
        return f"missing key '{loc}'"
    msg = err["msg"].removeprefix("Value error, ")
    return f"key '{loc}': {msg} (got {quoted(err.get('input'))})"


def _keys_at(loc: tuple) -> list[str]:
    """The keys a config mapping at ``loc`` (pydantic's location of its parent) takes:
    the fields of the section's model, found by walking :class:`RunConfig`'s fields; an
    empty list where the walk does not reach a model (a list item of a union)."""
    import typing

    from pydantic import BaseModel

    model: type[BaseModel] | None = RunConfig
    for part in loc:
        if model is None or isinstance(part, int):
            continue
        field_ = model.model_fields.get(str(part))
        if field_ is None:
            return []
        found = None
        for arg in (field_.annotation, *typing.get_args(field_.annotation)):
            for cand in (arg, *typing.get_args(arg)):
                if isinstance(cand, type) and issubclass(cand, BaseModel):
                    found = cand
        model = found
    if model is None:
        return []
    return [f.alias or name for name, f in model.model_fields.items()
            if not name.startswith("_") and name not in ("base_dir", "source")]


def _expanded_size(raw: object, limit: int) -> int:
    """How many values ``raw`` holds with every YAML alias expanded (``yaml.safe_load``
    shares one object for all the uses of an anchor, so the walk is memoised on object
    identity and stops past ``limit``); a structure that contains itself counts as
    ``limit + 1``. Iterative: no recursion limit on deeply nested input."""
    sizes: dict[int, int] = {}
    stack: list[tuple[object, bool]] = [(raw, False)]
    open_: set[int] = set()
    while stack:
        node, done = stack.pop()
        if not isinstance(node, list | dict):
            continue
        key = id(node)
        children = list(node.values()) if isinstance(node, dict) else node
        if done:
            open_.discard(key)
            sizes[key] = min(limit + 1, 1 + sum(
                sizes.get(id(c), 1) if isinstance(c, list | dict) else 1 for c in children))
            continue
        if key in sizes:
            continue
        if key in open_:
            return limit + 1  # refers to itself
        open_.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in children if isinstance(c, list | dict)
                     and id(c) not in sizes)
    return sizes.get(id(raw), 1)


def _clean_loc(loc) -> str:
    # pydantic adds union member names (e.g. 'str', 'SignalConfig') into the location
    parts = [str(p) for p in loc if str(p) not in {"str", "SignalConfig", "list[int]",
                                                      "list[str]", "literal['all']"}]
    return ".".join(parts)


def _check_data(cfg: RunConfig, source: str) -> None:
    d = cfg.data
    given = [k for k in ("dataset", "path", "paths") if getattr(d, k)]
    if len(given) != 1:
        raise UserError(f"{source}: key 'data': give exactly one of dataset, path or paths")
    if not d.dataset and (d.input is None or d.output is None):
        raise UserError(f"{source}: key 'data': 'input' and 'output' are required with a path")
    check_section(d, source)
