"""Every code block of the documentation site (docs/**/*.md, any page added later included) is real, as the README's
are (test_readme.py): per page, in order, in a scratch folder beside the bundled data and pipelines,

- Python blocks run, sharing one namespace;
- every `sloshid` command line in a bash block parses, and on blocks marked `<!-- docs-test: run -->` it runs and
  exits 0;
- TOML and JSON blocks load (a TOML block marked `<!-- docs-test: file PATH -->` is written there for later blocks);
- `text` blocks are output and are not run; a block marked `<!-- docs-test: skip -->` is illustrative and is not run.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest
from docblocks import Block, blocks, command_lines

from sloshid.cli.app import COMMANDS, build_parser, main

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md") if "hooks" not in p.parts)
LANGUAGES = {"python", "bash", "toml", "json", "text", ""}


def _scratch(tmp_path: Path, monkeypatch) -> None:
    """A reader's session in the repository: the bundled data and pipelines beside, outputs under out/."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for name in ("data", "pipelines"):
        os.symlink(ROOT / name, tmp_path / name)
    (tmp_path / "out").mkdir()


def _where(page: str, block: Block) -> str:
    return f"docs/{page}, the block at line {block.line}"


def _parses(words: list[str]) -> bool:
    try:
        build_parser(only=words[0]).parse_args(words)
    except SystemExit:  # argparse refused it
        return False
    return True


def _run(page: str, block: Block, namespace: dict, tmp_path: Path, capsys) -> None:
    """Run one block as the module docstring says."""
    where = _where(page, block)
    if block.marker == "file":
        target = tmp_path / block.argument
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(block.code, encoding="utf-8")
    if block.lang == "python":
        exec(compile(block.code, where, "exec"), namespace)
    elif block.lang == "bash":
        for words in command_lines(block.code):
            assert _parses(words), f"{where}: does not parse: sloshid {' '.join(words)}"
            if block.marker == "run":
                code = main(words)
                err = capsys.readouterr().err
                assert code == 0, f"{where}: sloshid {' '.join(words)} exited {code}: {err}"
    elif block.lang == "toml":
        tomllib.loads(block.code)
    elif block.lang == "json":
        json.loads(block.code)


def test_the_site_has_pages():
    assert {"index.md", "getting-started.md", "own-setup.md", "method.md"} <= set(PAGES)


@pytest.mark.parametrize("page", PAGES)
def test_every_code_block_runs(page, tmp_path, monkeypatch, capsys):
    found = blocks((DOCS / page).read_text(encoding="utf-8"))
    unknown = [f"{_where(page, b)}: ```{b.lang}" for b in found if b.lang not in LANGUAGES]
    assert not unknown, f"a fence language the tests do not run (use one of {sorted(LANGUAGES)}): {unknown}"
    if not any(b.lang in {"python", "bash", "toml", "json"} and b.marker != "skip" for b in found):
        return
    _scratch(tmp_path, monkeypatch)
    namespace: dict = {}
    for block in found:
        if block.marker != "skip":
            _run(page, block, namespace, tmp_path, capsys)


def test_the_docs_show_every_command():
    shown = {
        words[0]
        for page in PAGES
        for block in blocks((DOCS / page).read_text(encoding="utf-8"), "bash")
        for words in command_lines(block.code)
    }
    assert shown == set(COMMANDS)


def test_getting_started_runs_the_whole_chain():
    # the walk from the sample video to a robot trajectory is run for real, not only parsed
    text = (DOCS / "getting-started.md").read_text(encoding="utf-8")
    run = [words[0] for block in blocks(text, "bash") if block.marker == "run" for words in command_lines(block.code)]
    assert run == ["inspect", "track", "identify", "plan", "compare"]
