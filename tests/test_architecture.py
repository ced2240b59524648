"""The package layout's rules: stage packages import only downward (ARCHITECTURE.md), and importing sloshid
stays light and changes no global state."""

from __future__ import annotations

import ast
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
