"""The shape of the package: no import cycle, small modules, the shipped schema current."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pipeline.cli import app
from pipeline.schema import json_schema_text

PKG = Path(__file__).resolve().parent.parent / "pipeline"
MAX_LINES = 400


def _module_name(path: Path) -> str:
    parts = path.relative_to(PKG.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _resolve(module: str, is_package: bool, level: int, name: str | None) -> str:
    """The absolute module of a (possibly relative) ``from ... import``."""
    if level == 0:
        return name or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def import_graph() -> dict[str, set[str]]:
    """Edges module -> pipeline modules it imports, anywhere in its source (function-level
    imports count too: a lazy import is still a dependency)."""
    files = {_module_name(p): p for p in PKG.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in files}
    for mod, path in files.items():
        is_pkg = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(mod, is_pkg, node.level, node.module)
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in files else base
                           for a in node.names]
            for t in targets:
                while t and t not in files:  # pipeline.x.y where y is a name, not a module
                    t = t.rpartition(".")[0]
                if t.startswith("pipeline") and t != mod:
                    graph[mod].add(t)
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as a list of modules, or None (depth-first search)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state and (c := visit(n)):
                return c
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (c := visit(m)):
            return c
    return None


def test_import_graph_has_no_cycle():
    graph = import_graph()
    # the package re-exports its API lazily (module __getattr__): edges from the package
    # itself are the API table, not dependencies of the core
    graph["pipeline"] = set()
    assert len(graph) > 30 and sum(map(len, graph.values())) > 50  # the graph is real
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))


def test_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_core_does_not_import_the_edges():
    """Segmentation, methods, models and simulation never import I/O, reports or the CLI."""
    graph = import_graph()
    inner = {"segment", "signal", "models", "simulate", "methods", "events", "record", "metrics"}
    core = [m for m in graph if m.split(".")[1:2] and m.split(".")[1] in inner]
    edges = ("pipeline.io", "pipeline.report", "pipeline.cli", "pipeline.run",
             "pipeline.batch", "pipeline.config")
    bad = {m: sorted(n for n in graph[m] if n.startswith(edges)) for m in core}
    assert not {m: v for m, v in bad.items() if v}


@pytest.mark.parametrize("path", sorted(PKG.rglob("*.py")), ids=lambda p: p.name)
def test_modules_are_small(path):
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{path.relative_to(PKG.parent)} has {n} lines"


def test_shipped_schema_is_the_generated_one():
    shipped = (PKG / "data" / "results.schema.json").read_text(encoding="utf-8")
    assert shipped == json_schema_text(), "regenerate: pipeline schema > " \
        "pipeline/data/results.schema.json"


def test_schema_and_version_commands():
    runner = CliRunner()
    r = runner.invoke(app, ["schema"])
    assert r.exit_code == 0
    schema = json.loads(r.output)
    assert schema["title"] == "pipeline results.json"
    assert {"schema_version", "records"} <= set(schema["properties"])
    r = runner.invoke(app, ["--version"])
    assert r.exit_code == 0 and r.output.startswith("pipeline ")


def test_public_api_names_stay_functions():
    """``pipeline.analyse`` etc. are the functions, also after their modules were imported
    (a submodule named like its function would shadow it on the package)."""
    import importlib

    import pipeline

    for mod in PKG.rglob("*.py"):
        if mod.name != "__main__.py":  # that one runs the command line
            importlib.import_module(_module_name(mod))
    for name in ("analyse", "identify", "load", "segment", "simulate", "run_config",
                 "event_data", "identify_file"):
        assert callable(getattr(pipeline, name)) and not isinstance(
            getattr(pipeline, name), type(pipeline)), name
    assert set(pipeline.__all__) <= set(dir(pipeline))
