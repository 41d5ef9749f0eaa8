"""The ``data:`` section of a config: the common keys plus every format's keys, checked
against the format of the files.

:data:`DataConfig` is built from the registry: :class:`~pipeline.io.base.DataSection`'s
common keys, ``format`` with the registry's format names as its choices, and each format
option as an optional key (several formats may take the same key, declared alike). So a key
no format takes is pydantic's ``unknown key``, and a key of another format is caught by
:func:`check_keys` with one line naming the key and the formats that take it, as early as
the format is known: at config load (:func:`check_section`: a declared format, file names
or globs with a known suffix, a registry dataset), else per file when a run resolves them
(:func:`check_file`), and always in :func:`~pipeline.io.load_record`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

from pydantic import ValidationError, create_model
from pydantic.fields import FieldInfo

from ..errors import UserError
from ..quoting import quoted
from .base import DataSection, Format, SignalConfig, Strict
from .datasets import load_registry
from .registry import FORMATS, NAMES, SUFFIXES, find_format, formats_taking

__all__ = ["DataConfig", "SignalConfig", "check_file", "check_keys", "check_section",
           "config_key", "does_not_apply", "format_keys", "options_for"]


def _format_fields() -> dict[str, tuple[Any, FieldInfo]]:
    """Every format option as an optional ``data:`` field (default None: not given)."""
    fields: dict[str, tuple[Any, FieldInfo]] = {}
    for fmt in FORMATS.values():
        for key, info in fmt.options.model_fields.items():
            if key in DataSection.model_fields:
                raise TypeError(f"format {fmt.name!r}: option {key!r} is a common data key")
            field = (info.annotation | None, FieldInfo.merge_field_infos(info, default=None))
            seen = fields.setdefault(key, field)
            if (seen[0], seen[1].metadata) != (field[0], field[1].metadata):
                raise TypeError(f"format {fmt.name!r}: option {key!r} is declared unlike "
                                "in the other formats that take it")
    return fields


#: The ``data:`` section: the common keys and every format's keys (see the module docstring).
DataConfig: type[DataSection] = create_model(
    "DataConfig", __base__=DataSection, __module__=__name__,
    __doc__="Where the log is, which signals are the input and the output, and the keys of "
            "its format (one model per format in pipeline.io).",
    format=(Literal[tuple(NAMES)] | None, None), **_format_fields(),
)

#: The keys that belong to a format (not common to all).
FORMAT_KEYS: tuple[str, ...] = tuple(k for k in DataConfig.model_fields
                                     if k not in DataSection.model_fields)


def format_keys(data: DataSection) -> dict[str, Any]:
    """The format keys the section gives (a key set to null counts as not given)."""
    return {k: getattr(data, k) for k in FORMAT_KEYS if getattr(data, k, None) is not None}


def does_not_apply(key: str, fmt: Format) -> str:
    """``does not apply to dat files (it is an option of: mcap)``: the one wording."""
    return (f"does not apply to {fmt.name} files (it is an option of: "
            f"{', '.join(formats_taking(key))})")


def check_keys(data: DataSection, fmt: Format, where: str, matched: Path | None = None) -> None:
    """A :class:`UserError` for the first given key that ``fmt`` does not take.

    ``where`` starts the line (the config file, or the log); ``matched`` is the file that
    made the format known, when that was the files of a folder or a glob.
    """
    for key in format_keys(data):
        if key not in fmt.keys:
            also = f"; the path matches {matched}" if matched is not None else ""
            raise UserError(f"{where}: key 'data.{key}' {does_not_apply(key, fmt)}{also}")


def config_key(key: str) -> str:
    """How a config names a data key in an error: ``key 'data.time'``."""
    return f"key 'data.{key}'"


def options_for(data: DataSection, fmt: Format, where: str,
                label: Callable[[str], str] = config_key) -> Strict:
    """The section's keys for ``fmt`` as ``fmt``'s options model (its defaults filled in);
    a key of another format, or keys that contradict each other, are a :class:`UserError`
    naming the key as ``label`` does (the config's key path, or the command-line option)."""
    check_keys(data, fmt, where)
    try:
        return fmt.options.model_validate(format_keys(data))
    except ValidationError as exc:
        err = exc.errors()[0]
        key = ".".join(str(p) for p in err["loc"][:1])
        msg = err["msg"].removeprefix("Value error, ")
        raise UserError(f"{where}: {label(key)}: {msg} (got {quoted(err.get('input'))})") from None


def section_formats(data: DataSection) -> list[Format] | None:
    """The formats of the files the section names, when the section alone tells: a declared
    format, a registry dataset's format, or file names and globs with known suffixes. None
    when only the files will tell (a folder, a glob without a suffix, an unknown dataset)."""
    if data.format:
        return [NAMES[data.format]]
    if data.dataset:
        ds = load_registry().get(data.dataset)
        fmt = NAMES.get(ds.format) if ds is not None else None
        return [fmt] if fmt is not None else None
    patterns = [data.path] if data.path else list(data.paths or [])
    found = [SUFFIXES.get(Path(p).suffix.lower()) for p in patterns]
    if not found or None in found:
        return None
    return list(dict.fromkeys(found))


def check_section(data: DataSection, source: str) -> None:
    """At config load: the format keys against the formats the section names, if it does
    (keys of another format, keys that contradict each other)."""
    if not format_keys(data):
        return  # nothing to check (and no registry to read)
    for fmt in section_formats(data) or []:
        options_for(data, fmt, source)


def check_file(data: DataSection, path: Path, source: str) -> None:
    """When a run resolves its files: the format keys against one file's format (a file
    of unknown type is left to the loader, which says so)."""
    fmt = find_format(path, data.format)
    if fmt is not None:
        check_keys(data, fmt, source, matched=path)
