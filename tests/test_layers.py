"""The import graph of ``service/fmuid``: no cycle, no import from a lower layer to a higher one.

The graph is read from the source with :mod:`ast` (not by importing it): every ``import`` and
``from ... import`` statement, at module level and inside functions, except those under
``if TYPE_CHECKING:`` (annotations only, never executed). ``from a.b import c`` is an edge to the
module ``a.b.c`` when that is a module, else to ``a.b``.

The layers, lowest first; a module may import its own layer and lower ones only::

    fmuid (version, lazy facade) / errors / progress / frames (pandas tables) / provenance /
      processes (process hygiene: die with the parent, kill a group, cap memory) /
      readable (how numbers read)
      < data
      < model
      < formats (PEtab, SSV: read with the model's variables) / engine (runs tasks that simulate
        a model: in this process, local workers or dask)
      < estimation
      < profiling
      < discrepancy / experiment_design
      < results (reads every result kind back)
      < plots
      < report
      < stages / demo
      < settings (the service's configuration)
      < jobs / intake (checks and stages uploads; the job process loads its inputs there)
      < api / client
      < cli / console

Cycles are looked for between modules, whatever their layers.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "service" / "fmuid"

LAYERS = [
    {"fmuid", "errors", "progress", "frames", "provenance", "readable", "processes"},
    {"data"},
    {"model"},
    {"formats", "engine"},
    {"estimation"},
    {"profiling"},
    {"discrepancy", "experiment_design"},
    {"results"},
    {"plots"},
    {"report"},
    {"stages", "demo"},
    {"settings"},
    {"jobs", "intake"},
    {"api", "client"},
    {"cli", "console"},
]


def module_names() -> dict[str, Path]:
    """Return every module of the package by dotted name (packages by their ``__init__``)."""
    names = {}
    for path in PACKAGE.rglob("*.py"):
        parts = ["fmuid", *path.relative_to(PACKAGE).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        names[".".join(parts)] = path
    return names


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imported(node: ast.AST, name: str, is_package: bool) -> list[str]:
    """Return the dotted names an import statement in module ``name`` refers to."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    assert isinstance(node, ast.ImportFrom)
    base = node.module or ""
    if node.level:
        parent = name.split(".")
        parent = parent[: len(parent) - node.level + (1 if is_package else 0)]
        base = ".".join([*parent, base] if base else parent)
    return [f"{base}.{alias.name}" for alias in node.names] + [base]


def import_graph() -> dict[str, set[str]]:
    """Return module -> the package's modules it imports (TYPE_CHECKING blocks skipped)."""
    modules = module_names()
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        edges: set[str] = set()
        stack: list[ast.AST] = [ast.parse(path.read_text(encoding="utf-8"), str(path))]
        while stack:
            node = stack.pop()
            if isinstance(node, ast.If) and _is_type_checking(node):
                stack.extend(node.orelse)
                continue
            if isinstance(node, ast.Import | ast.ImportFrom):
                targets = _imported(node, name, is_package)
                if isinstance(node, ast.ImportFrom):
                    # ``from a import b``: the module a.b if there is one, else a itself
                    found = [t for t in targets[:-1] if t in modules]
                    targets = found if len(found) == len(targets) - 1 else [*found, targets[-1]]
                edges.update(t for t in targets if t in modules and t != name)
            stack.extend(ast.iter_child_nodes(node))
        graph[name] = edges
    return graph


def layer(module: str) -> int:
    """Return the layer index of a module (by its first name below ``fmuid``)."""
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else "fmuid"
    for index, names in enumerate(LAYERS):
        if top in names:
            return index
    raise AssertionError(f"{module}: its package {top!r} is in no layer of {__name__}.LAYERS")


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Return the strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for succ in sorted(graph[node]):
            if succ not in index:
                visit(succ)
                low[node] = min(low[node], low[succ])
            elif succ in on_stack:
                low[node] = min(low[node], index[succ])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_the_graph_sees_lazy_imports():
    graph = import_graph()
    assert "fmuid.jobs.run" in graph["fmuid.jobs.launcher"]  # imported inside a function
    assert "fmuid.data.limits" in graph["fmuid.settings"]
    assert "fmuid.stages" not in graph["fmuid"]  # only under TYPE_CHECKING


def test_cycle_finder_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]


def problems() -> set[str]:
    """Return every cycle and every upward import, one line each."""
    graph = import_graph()
    found = {"cycle " + ", ".join(component) for component in cycles(graph)}
    found.update(
        f"upward {source} -> {target}"
        for source, targets in graph.items()
        for target in targets
        if layer(target) > layer(source)
    )
    return found


def test_no_import_cycle_and_no_upward_import():
    found = problems()
    assert sorted(found) == [], "cycles or upward imports"
