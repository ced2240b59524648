"""The README's examples are real: every Python block runs (in order, in a scratch folder beside the bundled data)
and every `sloshid` command line in a bash block is a valid invocation of that command. The documentation site's
pages get the same treatment in test_docs.py."""

from __future__ import annotations

import json
import os
from pathlib import Path

import matplotlib.figure
import pytest
from docblocks import blocks, command_lines

from sloshid.cli.app import build_parser
from sloshid.core.outputs import REPORT_MARK

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
MAX_LINES = 150  # the README is the front page; the manual is the site (docs/)


def test_the_readme_is_a_front_page():
    assert len(README.splitlines()) <= MAX_LINES


def test_every_command_line_in_the_readme_parses():
    lines = [words for block in blocks(README, "bash") for words in command_lines(block.code)]
    assert {words[0] for words in lines} >= {"synth", "track", "identify", "plan", "compare", "run", "batch"}
    for words in lines:
        parser = build_parser(only=words[0])
        try:
            parser.parse_args(words)
        except SystemExit:  # argparse refused it
            pytest.fail(f"README command does not parse: sloshid {' '.join(words)}")


def test_ci_runs_exactly_the_readmes_test_command():
    # the README's second command is what CI runs: .ci/run's last line, character for character, in a bash block of
    # the README's opening (before its first section)
    command = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    opening = README.split("\n## ", 1)[0]
    assert "pytest" in command and command in [block.code.strip() for block in blocks(opening, "bash")]


def test_python_blocks_run_in_order(tmp_path, monkeypatch):
    # the blocks share one namespace and write under out/, as a reader's session in the repository would
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    os.symlink(ROOT / "data", tmp_path / "data")
    (tmp_path / "out").mkdir()
    namespace: dict = {}
    python = blocks(README, "python")
    assert python
    for block in python:
        exec(compile(block.code, "README.md", "exec"), namespace)
    # the chain's outputs are the real thing: the sample's liquid (Table I, f = 3.44 Hz) and a verified plan
    assert namespace["ident"].parameters["f_hz"].value == pytest.approx(3.44, rel=0.01)
    assert namespace["plan"].verification_ok
    # the comparison recommends a move and write_recommended writes it (it returned None when none was recommended)
    assert namespace["comparison"].recommended.key == "sloshid_robust"
    assert (tmp_path / "out" / "move.csv").stat().st_size > 0 and (tmp_path / "out" / "move.json").exists()
    # compare reused the plan instead of solving it again: the same solve time, the same move to one 1 kHz sample
    reused = namespace["comparison"].result("sloshid")
    assert reused.build_time_s == namespace["plan"].solve_time_s
    assert reused.score.transfer_time_s == pytest.approx(namespace["plan"].T_s, abs=1e-3)
    # every result behaves alike: text, JSON-safe dict, a figure, an HTML page, a table
    for name in ("tracked", "ident", "plan", "comparison"):
        result = namespace[name]
        assert result.summary().strip(), name
        json.dumps(result.to_dict(), allow_nan=False)
        assert isinstance(result.plot(), matplotlib.figure.Figure), name
        page = result.report(tmp_path / f"{name}_report")
        assert REPORT_MARK in page.read_text(encoding="utf-8"), name
        assert len(result.to_pandas()) > 0, name
