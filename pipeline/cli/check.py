"""``pipeline run CONFIG --check`` and ``pipeline schema --config`` (issue 29): a config
checked without identifying anything (its keys, every file it names, each file's
columns), and the JSON Schema of the config for editors."""

from __future__ import annotations

import json
from dataclasses import dataclass

from ..config import RunConfig, load_config
from ..errors import ExitCode, UserError


@dataclass(frozen=True)
class CheckedRecord:
    """One record a config names: ``error`` when it cannot be loaded, else its size."""

    name: str
    path: str
    samples: int = 0
    span: float = 0.0
    error: str | None = None

    def line(self) -> str:
        if self.error:
            return f"{self.name}: {self.error}"
        return f"{self.name}: ok, {self.samples} samples over {self.span:.6g} s ({self.path})"


def check_config(config) -> tuple[int, list[CheckedRecord]]:
    """Load ``config`` (a path or a :class:`RunConfig`), resolve its records and load
    each one (the file read, the columns found, the time checked), identifying nothing.
    The exit code as ``pipeline run`` gives it: 0 every record loads, 3 some do not, 2
    none does; a bad config itself is a :class:`UserError`."""
    from ..io import load_record
    from ..run import effective_data, resolve_specs

    cfg = config if isinstance(config, RunConfig) else load_config(config)
    rows = []
    for spec in resolve_specs(cfg):
        try:
            rec = load_record(spec.path, effective_data(cfg, spec), name=spec.name)
        except UserError as exc:
            rows.append(CheckedRecord(spec.name, spec.path, error=exc.message))
            continue
        rows.append(CheckedRecord(spec.name, spec.path, rec.n_samples,
                                  float(rec.t[-1] - rec.t[0]) if rec.n_samples else 0.0))
    bad = sum(r.error is not None for r in rows)
    code = (ExitCode.USER_ERROR if rows and bad == len(rows) else
            ExitCode.SOME_FAILED if bad else ExitCode.OK)
    return int(code), rows


def config_schema_text() -> str:
    """The JSON Schema of a run config (:class:`RunConfig`), without the two fields the
    loader sets itself (the config's folder and path)."""
    schema = RunConfig.model_json_schema()
    for key in ("base_dir", "source"):
        schema.get("properties", {}).pop(key, None)
    schema["title"] = "pipeline run config"
    return json.dumps(schema, indent=1, sort_keys=True) + "\n"
