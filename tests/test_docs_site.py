"""The documentation site builds with no warning (`mkdocs build --strict`), every page is in its navigation, and its
generated parts are complete: every command and option in the command-line reference, every field of the settings
classes on the settings page, every benchmark report included. Its code blocks are run by test_docs.py."""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from sloshid.cli.app import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _hook():
    """docs/hooks/generated.py, the MkDocs hook that writes the generated parts."""
    spec = importlib.util.spec_from_file_location("sloshid_docs_hook", DOCS / "hooks" / "generated.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _nav_pages(entries) -> set[str]:
    pages: set[str] = set()
    for entry in entries:
        values = entry.values() if isinstance(entry, dict) else [entry]
        for value in values:
            pages |= _nav_pages(value) if isinstance(value, list) else {value}
    return pages


@pytest.mark.slow
def test_the_site_builds_without_warnings(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    log = done.stdout + done.stderr
    assert done.returncode == 0 and "WARNING" not in log, log
    assert (tmp_path / "site" / "reference" / "cli" / "index.html").is_file()
    # every field of every settings class the settings page names is documented there
    page = (tmp_path / "site" / "reference" / "settings" / "index.html").read_text(encoding="utf-8")
    names = re.findall(r"^::: (\S+)$", (DOCS / "reference" / "settings.md").read_text(encoding="utf-8"), flags=re.M)
    assert len(names) >= 5
    for name in names:
        module, cls = name.rsplit(".", 1)
        for field in dataclasses.fields(getattr(importlib.import_module(module), cls)):
            assert f'id="{name}.{field.name}"' in page, f"{name}.{field.name}"


def test_every_page_is_in_the_navigation():
    # a new page (docs/upright_and_trays.md, say) must be given its place in mkdocs.yml's nav
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md") if "hooks" not in p.parts}
    assert pages == _nav_pages(config["nav"])


def test_the_cli_reference_has_every_command_and_option():
    reference = _hook().cli_reference()
    for name in COMMANDS:
        assert f"## `sloshid {name}`" in reference
        parser = build_parser(only=name)
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
        for action in sub._actions:
            for option in action.option_strings:
                assert option in reference, (name, option)


def test_every_benchmark_report_is_on_a_benchmark_page():
    included = "".join(p.read_text(encoding="utf-8") for p in (DOCS / "benchmarks").glob("*.md"))
    for report in sorted((ROOT / "reports" / "benchmarks").glob("*.md")):
        assert f'--8<-- "reports/benchmarks/{report.name}"' in included, report.name
