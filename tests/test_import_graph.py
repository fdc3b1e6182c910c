"""The package's import graph flows one way and has no cycles.

The parts follow the data flow sim → data → tasks → cot → model → train → evaluate → recipes → serve → cli:
a module may import its own part and earlier ones, never a later one, so each part can be used (and tested)
without the parts built on top of it. Every import counts, including one inside a function: a lazy import is
still a dependency, only a deferred one. The check reads the source with ``ast`` and imports nothing.
"""

from __future__ import annotations

import ast
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "src" / "tacreasoner"

FLOW = ("sim", "data", "tasks", "cot", "model", "train", "evaluate", "recipes", "serve", "cli")
"""The parts in data-flow order; a module may import only its own part and the ones before it."""
ROOT = "root"
"""Leaf helpers at the package root: importable by every part, importing only each other."""
ROOT_MODULES = frozenset({"__init__", "fields", "jsonl", "yamlfile", "progress", "video_io", "intervals"})
"""The root's own modules. ``__init__`` is here so that importing any part (say ``tacreasoner.sim``) stays light."""
CLI_ROOT_MODULES = frozenset({"__main__"})
"""Root-level modules of the command line (the ``cli/`` package is part ``cli`` by its name)."""
PART_OF_PACKAGE: dict[str, str] = {}
"""Sub-packages that count as another part (none today: every sub-package is a part of the flow)."""

Graph = dict[str, set[str]]


def find_modules(package_dir: Path) -> dict[str, Path]:
    """Dotted module name → file for every ``.py`` under ``package_dir`` (a package's name is its ``__init__``'s)."""
    top = package_dir.name
    modules = {}
    for path in sorted(package_dir.rglob("*.py")):
        parts = [top, *path.relative_to(package_dir).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path
    return modules


def _resolve(target: str, modules: Mapping[str, Path]) -> str | None:
    """The module ``target`` names, or its longest prefix that is one (a name inside it); None when outside."""
    parts = target.split(".")
    while parts:
        name = ".".join(parts)
        if name in modules:
            return name
        parts.pop()
    return None


def imports_of(name: str, path: Path, modules: Mapping[str, Path]) -> set[str]:
    """The package's modules that ``name`` imports anywhere in its source (top level, functions, branches).

    Relative imports are resolved against the module's package; ``from pkg import x`` counts as importing
    ``pkg.x`` when that is a module, else ``pkg``. Importing a submodule does not count as importing its
    parent packages (Python runs their ``__init__`` too, but that is the parent's own business).
    """
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, *([base] if base else [])])
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
        for target in targets:
            resolved = _resolve(target, modules)
            if resolved is not None and resolved != name:
                found.add(resolved)
    return found


def import_graph(package_dir: Path) -> Graph:
    """Module → the package's modules it imports."""
    modules = find_modules(package_dir)
    return {name: imports_of(name, path, modules) for name, path in modules.items()}


def part_of(module: str) -> str:
    """The flow part a module belongs to: its first sub-package, or a root module's classification.

    A root-level module that is neither a listed helper nor part of the command line raises: a new module
    at the root must be given its place here, not slip past the check.
    """
    parts = module.split(".")
    if len(parts) == 1:
        return ROOT
    first = parts[1]
    if len(parts) == 2 and first in ROOT_MODULES:
        return ROOT
    if len(parts) == 2 and first in CLI_ROOT_MODULES:
        return "cli"
    first = PART_OF_PACKAGE.get(first, first)
    if first not in FLOW:
        raise ValueError(f"{module}: not in any part of the flow; classify it in tests/test_import_graph.py")
    return first


def upward_edges(graph: Graph, part: Callable[[str], str], flow: tuple[str, ...] = FLOW) -> list[str]:
    """Each import of a later part (or of anything but the root from the root), as ``a (part) -> b (part)``."""
    rank = {ROOT: -1, **{p: i for i, p in enumerate(flow)}}
    bad = []
    for source in sorted(graph):
        for target in sorted(graph[source]):
            s, t = part(source), part(target)
            if rank[t] > rank[s] or (s == ROOT and t != ROOT):
                bad.append(f"{source} ({s}) -> {target} ({t})")
    return bad


def import_groups(graph: Graph) -> list[set[str]]:
    """The strongly connected groups of two or more modules: each member reaches every other by imports."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[set[str]] = []

    def visit(root: str) -> None:  # Tarjan's algorithm, iterative so deep chains cannot hit the recursion limit
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        group.add(member)
                        if member == node:
                            break
                    if len(group) > 1:
                        groups.append(group)
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph.get(child, ())))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(groups, key=sorted)


def cycles(graph: Graph) -> list[list[str]]:
    """One closed path ``[a, b, …, a]`` per group of modules that import each other (a shortest one through the
    group's first module); the group may hold more modules, in further cycles through the same ones."""
    return [_closed_path(sorted(group)[0], group, graph) for group in import_groups(graph)]


def _closed_path(start: str, group: set[str], graph: Graph) -> list[str]:
    """A shortest path from ``start`` back to itself inside ``group`` (breadth first), to name in a message."""
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for child in sorted(graph.get(node, ())):
                if child not in group:
                    continue
                if child == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(previous[path[-1]])
                    return [*reversed(path), start]
                if child not in previous:
                    previous[child] = node
                    following.append(child)
        frontier = following
    raise AssertionError(f"{start} is in a cycle but no path leads back to it")  # cannot happen for an SCC


def _lines(items: Iterable[str]) -> str:
    return "\n  " + "\n  ".join(items)


# ------------------------------------------------------------------------------------------------ the package


def test_the_checker_sees_the_whole_package() -> None:
    graph = import_graph(PACKAGE_DIR)
    assert len(graph) > 100, sorted(graph)
    assert "tacreasoner.model.modeling" in graph["tacreasoner.model.build"]  # a top-level import
    assert "tacreasoner.train.precision" in graph["tacreasoner.train.trainer"]
    unplaced = []
    for module in graph:
        try:
            part_of(module)
        except ValueError as error:
            unplaced.append(str(error))
    assert not unplaced, _lines(unplaced)


def test_no_module_imports_a_later_part_of_the_flow() -> None:
    bad = upward_edges(import_graph(PACKAGE_DIR), part_of)
    assert not bad, f"imports against the flow {' -> '.join(FLOW)}:{_lines(bad)}"


def test_no_import_cycles() -> None:
    graph = import_graph(PACKAGE_DIR)
    found = []
    for group in import_groups(graph):
        path = _closed_path(sorted(group)[0], group, graph)
        more = f"  (the group also holds {', '.join(sorted(group - set(path)))})" if len(group) > len(path) - 1 else ""
        found.append(" -> ".join(path) + more)
    assert not found, "modules that import each other (each line a cycle):" + _lines(found)


# ------------------------------------------------------------------------------------------------ the checker


def _fake_package(root: Path, files: Mapping[str, str]) -> Path:
    for relative, text in {"__init__.py": "", "sim/__init__.py": "", "data/__init__.py": "", **files}.items():
        path = root / "fake" / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root / "fake"


def _fake_part(module: str) -> str:
    parts = module.split(".")
    return ROOT if len(parts) == 1 or parts[1] == "helper" else parts[1]


def test_the_checker_catches_a_planted_upward_import_and_cycle(tmp_path: Path) -> None:
    package = _fake_package(tmp_path, {
        "helper.py": "import os\n",
        "sim/clean.py": "from fake import helper\nfrom . import shapes\n",
        "sim/shapes.py": "X = 1\n",
        "sim/lazy.py": "def later():\n    from ..data import reader\n    return reader\n",  # upward, lazily
        "data/reader.py": "import fake.data.writer\nfrom fake.sim.shapes import X\n",
        "data/writer.py": "def f():\n    from fake.data import reader\n",  # reader ↔ writer
    })
    graph = import_graph(package)
    assert graph["fake.sim.clean"] == {"fake.helper", "fake.sim.shapes"}
    assert graph["fake.data.reader"] == {"fake.data.writer", "fake.sim.shapes"}
    assert upward_edges(graph, _fake_part, ("sim", "data")) == ["fake.sim.lazy (sim) -> fake.data.reader (data)"]
    assert cycles(graph) == [["fake.data.reader", "fake.data.writer", "fake.data.reader"]]


def test_the_checker_names_a_longer_cycle_and_a_root_helper_importing_a_part(tmp_path: Path) -> None:
    package = _fake_package(tmp_path, {
        "helper.py": "from fake.sim import a\n",
        "sim/a.py": "from fake.sim import b\n",
        "sim/b.py": "import fake.sim.c\n",
        "sim/c.py": "from .a import thing\n",
    })
    graph = import_graph(package)
    assert upward_edges(graph, _fake_part, ("sim", "data")) == ["fake.helper (root) -> fake.sim.a (sim)"]
    assert cycles(graph) == [["fake.sim.a", "fake.sim.b", "fake.sim.c", "fake.sim.a"]]


def test_the_checker_places_the_real_modules() -> None:
    assert part_of("tacreasoner") == part_of("tacreasoner.jsonl") == ROOT
    assert {part_of(m) for m in ("tacreasoner.cli.serve", "tacreasoner.__main__", "tacreasoner.cli.app")} == {"cli"}
    assert part_of("tacreasoner.recipes.quickstart") == "recipes"
    assert part_of("tacreasoner.model.heads.cross_video") == "model"
