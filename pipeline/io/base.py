"""What every input format is made of: a strict options model and a registry entry.

A format is one module in ``pipeline/io/`` that declares a :class:`Format`: its name, its
file suffixes, its options model (the ``data:`` keys that apply to it, beside the common
ones of :class:`DataSection`) and its load function. :mod:`pipeline.io.registry` lists the
formats; nothing else names them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from ..errors import UserError
from ..record import Record


class Strict(BaseModel):
    """Frozen, and a key that is not declared is an error (never silently ignored)."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class SignalConfig(Strict):
    """A numeric field of an MCAP topic, e.g. ``{topic: /plate/temp, field: temperature.value}``."""

    topic: str
    field: str


class DataSection(Strict):
    """The keys of the ``data:`` section that every format shares: where the log is, which
    signals are the input and the output, their units and the input before the first row.

    The format keys (``time``, ``stamp``, ...) belong to the formats' options models;
    :class:`pipeline.io.options.DataConfig` adds them, and ``format``'s choices, from the
    registry.
    """

    dataset: str | None = None
    path: str | None = Field(None, description="a file, a folder or a glob")
    paths: list[str] | None = None
    format: str | None = None
    input: str | int | SignalConfig | None = None
    output: str | int | SignalConfig | None = None
    initial_input: float | None = None
    setpoint: str | int | SignalConfig | None = Field(
        None, description="a closed loop's setpoint, read like the input: the input is "
        "then the controller output, and the controller's settings are read off the log")
    units: dict[Literal["time", "input", "output"], str] | None = None

    def unit_map(self) -> dict[str, str]:
        return dict(self.units or {})


#: ``load(path, data, options, name)``: one file as a Record; problems are UserErrors.
Loader = Callable[[Path, DataSection, Strict, str], Record]


def column_name(text: str) -> str:
    """A tabular format's ``--input``/``--output``: the column name (or position) as given."""
    return text


@dataclass(frozen=True)
class Places:
    """Where each data row of a table is in its file, for error lines and notes:
    ``places(i)`` is e.g. ``line 14`` or ``sheet 'Log' row 14``."""

    path: Path
    numbers: Sequence[int]
    word: str = "line"
    prefix: str = ""

    def __call__(self, i: int) -> str:
        return f"{self.prefix}{self.word} {self.numbers[i]}"

    def error(self, i: int, text: str) -> UserError:
        """``FILE: line N: text`` as a :class:`UserError`."""
        return UserError(f"{self.path}: {self(i)}: {text}")


@dataclass(frozen=True)
class Format:
    """One input format, as the registry knows it.

    ``options`` is the model of the ``data:`` keys that apply to this format (every field
    optional; its defaults are the format's); ``parse_signal`` turns a command-line
    ``--input``/``--output`` into the ``data.input``/``data.output`` value; ``aliases``
    are other names ``data.format`` may give it (``tsv`` for ``csv``).
    """

    name: str
    suffixes: tuple[str, ...]
    options: type[Strict]
    load: Loader
    parse_signal: Callable[[str], str | SignalConfig] = column_name
    aliases: tuple[str, ...] = ()

    @property
    def keys(self) -> frozenset[str]:
        """The ``data:`` keys of this format (beside the common ones)."""
        return frozenset(self.options.model_fields)
