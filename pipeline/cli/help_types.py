"""How ``--help`` shows what an option takes (issue 29): click's words, not typer's.

typer 0.29 prints every option's Python annotation (``<bool>`` beside a flag, ``<str>``,
``<list[str]>``); a flag takes no value, and the others read as the values they take:
``TEXT``, ``NUMBER``, ``INTEGER``, ``PATH``, or the choices ``a|b``. An option with its
own ``metavar`` keeps it; the usage line names arguments as ``FILE``, not ``{file}``.
Each command's help ends with one example. This is the one place the CLI adjusts
typer's help."""

from __future__ import annotations

from typer.core import TyperArgument, TyperOption

#: typer's type label -> the value word shown.
VALUE_WORDS = {"str": "TEXT", "float": "NUMBER", "int": "INTEGER", "path": "PATH",
               "file": "FILE", "directory": "FOLDER"}


#: One example per command, shown at the end of its --help (the command's name -> a line).
EXAMPLES: dict[str, str] = {
    "run": "pipeline run configs/thermal.yaml --out reports/thermal (first: --check)",
    "identify": "pipeline identify log.csv --input u --output y --time time "
                "--units input=V,output=degC",
    "tune": "pipeline tune first_order K=2 T=10 delay=1 --rule simc --tau-c robust",
    "segment": "pipeline segment log.csv --input u --output y --time time --json",
    "methods": "pipeline methods --json | jq -r '.[].id'",
    "schema": "pipeline schema --config > pipeline-config.schema.json",
    "inspect": "pipeline inspect run.mcap --json",
    "datasets list": "pipeline datasets list --json",
    "datasets fetch": "pipeline datasets fetch daisy-heating",
    "datasets synth": "pipeline datasets synth datasets/examples/nightly --n 20 --corrupt 2",
    "baseline accept": "pipeline baseline accept reports/plant/results.json "
                       "--to reports/baselines/plant.json",
}


def example(command: str) -> str:
    """The ``--help`` epilog of ``command``: ``Example: ...`` (:data:`EXAMPLES`)."""
    return f"Example: {EXAMPLES[command]}"


def value_word(label: str | None) -> str | None:
    """``"<list[str]>"`` -> ``"TEXT"``, ``"<a|b>"`` -> ``"a|b"``, ``"<float>"`` ->
    ``"NUMBER"``; None stays None."""
    if not label:
        return label
    inner = label.strip("<>")
    if inner.startswith("list[") and inner.endswith("]"):
        inner = inner[5:-1]
    return VALUE_WORDS.get(inner.lower(), inner)


def _option_type(self: TyperOption, ctx) -> str | None:
    if self.metavar is not None:
        return self.metavar
    if self.is_flag or self.count:
        return None
    return value_word(_TYPER_OPTION(self, ctx))


def _argument_type(self: TyperArgument, ctx) -> str | None:
    return None  # an argument's name says what it is; its metavar is the name shown


def _usage_name(self: TyperArgument) -> str:
    """``FILE`` for a required argument and ``[FILE]`` for an optional one in the usage
    line (typer 0.29: ``{file}``)."""
    name = (self.metavar or self.name or "").upper()
    name = name if self.required else f"[{name}]"
    return name + ("..." if self.nargs != 1 else "")


_TYPER_OPTION = TyperOption.display_type_rich
TyperOption.display_type_rich = _option_type
TyperArgument.display_type_rich = _argument_type
if hasattr(TyperArgument, "_usage_display_name"):
    TyperArgument._usage_display_name = _usage_name
