"""docs/upright_and_trays.md's examples are real: its Python blocks run and every `sloshid` command line in its bash
blocks parses as that command (with files the docs name that exist)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from sloshid.cli.app import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "upright_and_trays.md").read_text(encoding="utf-8")


def _blocks(lang: str) -> list[str]:
    """The doc's fenced code blocks of one language, in order."""
    return re.findall(rf"```{lang}\n(.*?)```", DOC, flags=re.S)


def test_the_docs_python_blocks_run(monkeypatch):
    monkeypatch.chdir(ROOT)
    blocks = _blocks("python")
    assert len(blocks) == 2
    for block in blocks:
        exec(compile(block, "docs/upright_and_trays.md", "exec"), {})


@pytest.mark.parametrize("line", [b for block in _blocks("bash") for b in block.strip().splitlines()])
def test_the_docs_command_lines_parse(line):
    words = shlex.split(line)
    assert words[:3] == ["python3", "-m", "sloshid"] and words[3] in COMMANDS, line
    args = build_parser(only=words[3]).parse_args(words[3:])
    assert (ROOT / (args.pipeline if words[3] == "run" else args.scenario)).is_file()
    if getattr(args, "params", None):
        assert (ROOT / args.params).is_file()
