"""The package layout's rules: stage packages import only downward (ARCHITECTURE.md), no two sloshid modules import
each other (directly or round a longer loop, imports inside functions included), and importing sloshid stays light
and changes no global state."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "sloshid"

# Which sloshid subpackages each one may import (ARCHITECTURE.md, "Dependencies"); anything not listed is refused.
ALLOWED: dict[str, set[str]] = {
    "core": set(),
    "model": {"core"},
    "video": {"core"},
    "report": {"core"},
    "tracking": {"core", "video", "report"},
    "identification": {"core", "model", "report"},
    "planning": {"core", "model", "report"},
    "comparison": {"core", "model", "report", "planning"},
    "synthetic": {"core", "model", "video", "identification"},
    "validation": {"core", "model", "report", "identification"},
    "workflow": {"core", "model", "video", "report", "tracking", "identification", "planning", "comparison"},
    "cli": {
        "core",
        "model",
        "video",
        "report",
        "tracking",
        "identification",
        "planning",
        "comparison",
        "synthetic",
        "validation",
        "workflow",
    },
}


def _imported_subpackages(path: Path) -> set[str]:
    """The sloshid subpackages a module imports (at any depth, lazily or not)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "sloshid" and len(parts) > 1 and (PACKAGE / parts[1]).is_dir():
                found.add(parts[1])
    return found


def _module_name(path: Path) -> str:
    parts = ("sloshid", *path.relative_to(PACKAGE).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _runtime_imports(tree: ast.AST):
    """Every Import/ImportFrom node at any depth (inside functions too), except under `if TYPE_CHECKING:`: those never
    run, they only name a class for an annotation."""
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skipped |= {id(n) for n in ast.walk(node)}
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in skipped:
            yield node


def import_graph() -> dict[str, set[str]]:
    """Module -> the sloshid modules it imports (`from sloshid.a import b` names module sloshid.a.b when b is one)."""
    graph = {}
    for name, path in MODULES.items():
        deps = set()
        for node in _runtime_imports(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                full = [f"{node.module}.{a.name}" for a in node.names] if node.module else []
                deps |= {f if f in MODULES else node.module for f in full}
            else:
                deps |= {a.name for a in node.names}
        graph[name] = {d for d in deps if d in MODULES and d != name}
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
    return cycles


def test_the_cycle_finder_finds_a_loop_and_only_a_loop():
    assert import_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert import_cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles_among_sloshid_modules():
    graph = import_graph()
    cycles = import_cycles(graph)
    described = ["; ".join(f"{m} -> {', '.join(sorted(graph[m] & set(c)))}" for m in c) for c in cycles]
    assert not cycles, "modules that import each other (split out what both need): " + " | ".join(described)


def test_every_subpackage_has_a_rule_and_a_docstring_that_states_it():
    subpackages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    assert subpackages == set(ALLOWED)
    for name in subpackages:
        doc = ast.get_docstring(ast.parse((PACKAGE / name / "__init__.py").read_text()))
        assert doc and "May import" in doc, name


def test_imports_point_one_way():
    bad = []
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE)
        if len(rel.parts) < 2:
            continue  # top-level modules (the public API, __main__) sit above every stage
        own = rel.parts[0]
        for dep in _imported_subpackages(path) - {own}:
            if dep not in ALLOWED[own]:
                bad.append(f"{rel} imports sloshid.{dep}")
    assert not bad, "imports against ARCHITECTURE.md's direction: " + "; ".join(sorted(bad))


def test_no_relative_imports_that_could_hide_a_direction():
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            assert not (isinstance(node, ast.ImportFrom) and node.level > 0), path


def test_import_sloshid_is_light_and_changes_no_global_state():
    code = (
        "import sloshid, sys; "
        "print(sorted(m for m in sys.modules if m.startswith(('matplotlib', 'cv2', 'casadi', 'dask'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def _docstrings(tree: ast.AST) -> set[int]:
    """The string statements of a module: docstrings of modules, classes, functions and attributes (documentation,
    which may speak of the command line; never a message a user reads at run time)."""
    return {
        id(node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str)
    }


def test_the_library_names_settings_not_command_line_flags():
    # messages outside the command line name settings as the library knows them (`window_s`, through SettingError or in
    # backticks), and each front-end re-words them: a Python user never reads of an option they did not type
    flag = re.compile(r"--[a-z]")
    found = []
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] == "cli":
            continue
        tree = ast.parse(path.read_text())
        docs = _docstrings(tree)
        for node in ast.walk(tree):
            text = node.value if isinstance(node, ast.Constant) and id(node) not in docs else None
            if isinstance(text, str) and flag.search(text):
                found.append(f"{rel}:{node.lineno} {node.value[:60]!r}")
    assert not found, "messages naming a command-line flag: " + "; ".join(found)
