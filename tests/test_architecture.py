"""The shape of the package (DESIGN.md "Layout"): a folder per wing, no import cycle, no
folder that imports a folder importing it back, nothing outside a folder reaching into
its private modules, a pure core, modules that are one concept, the shipped schema
current. Each rule is a function on an import graph, tested on a small graph that breaks
it and then on the package's own."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pipeline.cli import app
from pipeline.schema import json_schema_text

PKG = Path(__file__).resolve().parent.parent / "pipeline"
#: A module may grow to about this many lines when it is one concept.
MAX_LINES = 600
#: The numerical core: pure functions on arrays and frozen dataclasses.
CORE = ("simulation", "segmentation", "methods", "refine", "grading", "models", "responses",
        "signal", "metrics", "uncertainty", "events", "record", "fit", "validate", "results",
        "analysis", "memory", "parallel")
#: What the core never imports: files, loaders, reports, the command line, the batch
#: layer, the gate, the config and the run.
EDGES = ("io", "report", "cli", "batch", "gate", "run", "config", "files", "api")
#: Top-level modules that are entry points: ``__main__`` runs the command line.
ENTRY_POINTS = ("pipeline.__main__",)


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


def _lazy_exports(tree: ast.Module) -> dict[str, str]:
    """A package's ``_EXPORTS`` table (name -> submodule), when it exports lazily."""
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id in ("_EXPORTS", "_API") for t in node.targets):
            return ast.literal_eval(node.value)
    return {}


def import_graph() -> dict[str, set[str]]:
    """Edges module -> pipeline modules it imports, anywhere in its source (function-level
    imports count too: a lazy import is still a dependency). A package that exports its
    names lazily (``_EXPORTS``) has an edge to each module the table names."""
    files = {_module_name(p): p for p in PKG.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in files}
    for mod, path in files.items():
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if is_pkg and mod != "pipeline":
            graph[mod] |= {f"{mod}.{sub}" for sub in _lazy_exports(tree).values()}
        for node in ast.walk(tree):
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
    # the package re-exports its API lazily: edges from the package itself are the API
    # table, not dependencies of the core
    graph["pipeline"] = set()
    return graph


def packages() -> set[str]:
    return {_module_name(p) for p in PKG.rglob("__init__.py")}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as a list of modules, or None (depth-first search)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
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


def wing(module: str) -> str:
    """The node a module belongs to when folders are collapsed: its top folder
    (``pipeline.refine.joint`` -> ``pipeline.refine``), or the top-level module itself."""
    parts = module.split(".")
    return ".".join(parts[:2])


def wing_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The import graph with every folder collapsed into one node (edges inside a folder
    dropped): a cycle here is a folder that imports a folder (or a top-level module)
    that imports it back."""
    out: dict[str, set[str]] = {}
    for m, deps in graph.items():
        out.setdefault(wing(m), set()).update(wing(d) for d in deps if wing(d) != wing(m))
    return out


def private_imports(graph: dict[str, set[str]], pkgs: set[str]) -> list[str]:
    """Edges that reach into a folder from outside it: the target's folder (the package
    that holds it; for a package, the one that holds that) is not the importer's and
    not one the importer is inside. Outside a folder only the folder itself is
    imported (its ``__init__`` exports the wing's public names)."""
    bad = []
    for m, deps in graph.items():
        inside = m if m in pkgs else m.rpartition(".")[0]
        for d in deps:
            holder = d.rpartition(".")[0]
            if d in pkgs and holder == "pipeline":
                continue  # a top folder itself
            if holder != "pipeline" and not (inside == holder
                                             or inside.startswith(holder + ".")):
                bad.append(f"{m} -> {d}")
    return sorted(bad)


def core_edges(graph: dict[str, set[str]]) -> list[str]:
    """Edges from a core module (:data:`CORE`) to the edges (:data:`EDGES`)."""
    def top(m: str) -> str:
        return m.split(".")[1] if m.count(".") else ""

    return sorted(f"{m} -> {d}" for m, deps in graph.items() if top(m) in CORE
                  for d in deps if top(d) in EDGES)


def api_modules() -> set[str]:
    """The modules the public API table of ``pipeline/__init__.py`` names (imported on
    first use of a name: the API's importer is its user)."""
    tree = ast.parse((PKG / "__init__.py").read_text(encoding="utf-8"))
    return {f"pipeline.{m}" for m in _lazy_exports(tree).values()}


def single_importer_modules(graph: dict[str, set[str]], pkgs: set[str],
                            public: set[str] = frozenset()) -> list[str]:
    """Top-level modules whose importers all sit in one folder: they belong in it (a
    module of the public API, ``public``, is imported by its users too)."""
    importers: dict[str, set[str]] = {m: set() for m in graph}
    for m, deps in graph.items():
        for d in deps:
            importers[d].add(m)
    out = []
    for m in graph:
        if m.count(".") != 1 or m in pkgs or m in ENTRY_POINTS or m in public:
            continue
        folders = {wing(i) for i in importers[m]}
        if len(folders) == 1 and next(iter(folders)) in pkgs and not any(
                i.count(".") == 1 and i not in pkgs for i in importers[m]):
            out.append(f"{m} (imported only from {next(iter(folders))})")
    return sorted(out)


# -- the rules on graphs that break them -------------------------------------------------

def test_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_a_folder_importing_a_folder_back_is_found():
    g = {"pipeline.refine.joint": {"pipeline.methods"}, "pipeline.methods": set(),
         "pipeline.methods.lsq": {"pipeline.refine"}, "pipeline.refine": set()}
    assert find_cycle(g) is None  # no module cycle...
    assert find_cycle(wing_graph(g)) == ["pipeline.methods", "pipeline.refine",
                                         "pipeline.methods"]  # ...but a folder cycle
    g["pipeline.methods.lsq"] = set()
    assert find_cycle(wing_graph(g)) is None


def test_a_private_module_imported_from_outside_is_found():
    pkgs = {"pipeline", "pipeline.refine", "pipeline.io", "pipeline.io.mcap"}
    g = {"pipeline.analysis": {"pipeline.refine", "pipeline.refine.joint"},
         "pipeline.refine.event": {"pipeline.refine.search"},
         "pipeline.io.registry": {"pipeline.io.mcap", "pipeline.io.mcap.reader"},
         "pipeline.io.mcap.inspect": {"pipeline.io.mcap.reader", "pipeline.io.base"},
         "pipeline.run": {"pipeline.io"}}
    assert private_imports(g, pkgs) == ["pipeline.analysis -> pipeline.refine.joint",
                                        "pipeline.io.registry -> pipeline.io.mcap.reader"]


def test_the_core_importing_an_edge_is_found():
    g = {"pipeline.refine.joint": {"pipeline.models", "pipeline.report.tables"},
         "pipeline.validate": {"pipeline.files"}, "pipeline.run": {"pipeline.io"}}
    assert core_edges(g) == ["pipeline.refine.joint -> pipeline.report.tables",
                             "pipeline.validate -> pipeline.files"]


def test_a_single_importer_module_is_found():
    pkgs = {"pipeline", "pipeline.refine"}
    g = {"pipeline.lstsq": set(), "pipeline.refine.problem": {"pipeline.lstsq"},
         "pipeline.refine.event": {"pipeline.lstsq", "pipeline.models"},
         "pipeline.models": set(), "pipeline.validate": {"pipeline.models"}}
    assert single_importer_modules(g, pkgs) == ["pipeline.lstsq (imported only from "
                                                "pipeline.refine)"]
    assert single_importer_modules(g, pkgs, {"pipeline.lstsq"}) == []


# -- the package -------------------------------------------------------------------------

def test_import_graph_has_no_cycle():
    graph = import_graph()
    assert len(graph) > 80 and sum(map(len, graph.values())) > 200  # the graph is real
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))


def test_no_folder_imports_a_folder_that_imports_it_back():
    cycle = find_cycle(wing_graph(import_graph()))
    assert cycle is None, " -> ".join(cycle)


def test_nothing_outside_a_folder_imports_its_private_modules():
    assert private_imports(import_graph(), packages()) == []


def test_core_does_not_import_the_edges():
    graph = import_graph()
    assert {wing(m) for m in graph} >= {f"pipeline.{c}" for c in CORE}  # the names are real
    assert core_edges(graph) == []


def test_top_level_modules_with_one_importer_live_in_its_folder():
    assert single_importer_modules(import_graph(), packages(), api_modules()) == []


def test_every_folder_says_what_it_does_and_exports_its_names():
    for init in sorted(PKG.glob("*/__init__.py")):
        tree = ast.parse(init.read_text(encoding="utf-8"))
        doc = ast.get_docstring(tree)
        assert doc and len(doc.split()) >= 8, f"{init.parent.name}: no docstring"
        names = {t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets
                 if isinstance(t, ast.Name)}
        assert "__all__" in names, f"{init.parent.name}/__init__.py has no __all__"


@pytest.mark.parametrize("path", sorted(PKG.rglob("*.py")), ids=lambda p: p.name)
def test_modules_are_one_concept_in_size(path):
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
    (a submodule named like its function would shadow it on the package), and so are
    the names a folder exports."""
    import importlib

    import pipeline

    for mod in PKG.rglob("*.py"):
        if mod.name != "__main__.py":  # that one runs the command line
            importlib.import_module(_module_name(mod))
    for name in ("analyse", "identify", "load", "segment", "simulate", "run_config",
                 "event_data", "identify_file", "load_results"):
        assert callable(getattr(pipeline, name)) and not isinstance(
            getattr(pipeline, name), type(pipeline)), name
    assert set(pipeline.__all__) <= set(dir(pipeline))
    for init in PKG.glob("*/__init__.py"):
        package = importlib.import_module(_module_name(init))
        for name in package.__all__:
            assert not isinstance(getattr(package, name), type(pipeline)), \
                f"{package.__name__}.{name} is a module"
