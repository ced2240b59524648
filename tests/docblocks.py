"""The fenced code blocks of a Markdown page (the README, the documentation site's pages), for the tests that run them.

A block may be preceded by one marker line, an HTML comment that the site does not show:

- `<!-- docs-test: skip -->`: an illustrative block, not run (say why in the text around it);
- `<!-- docs-test: run -->`: a bash block whose `sloshid` command lines are run, in order, not only parsed;
- `<!-- docs-test: file PATH -->`: the block is written to PATH (relative to the scratch folder) for later blocks.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass

from sloshid.cli.app import COMMANDS

FENCE = re.compile(r"^```([\w+-]*)[^\n]*\n(.*?)^```[ \t]*$", flags=re.S | re.M)
MARKER = re.compile(r"<!--\s*docs-test:\s*(skip|run|file)\b\s*(.*?)\s*-->\s*\n\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced block: its language (as written after the fence), its text, its marker and argument, its line."""

    lang: str
    code: str
    marker: str = ""
    argument: str = ""
    line: int = 0


def blocks(text: str, lang: str | None = None) -> list[Block]:
    """The page's fenced blocks in order (of one language when `lang` is given), each with the marker before it."""
    found = []
    for match in FENCE.finditer(text):
        before = text[: match.start()]
        marker = MARKER.search(before[-200:])
        found.append(
            Block(
                lang=match.group(1),
                code=match.group(2),
                marker=marker.group(1) if marker else "",
                argument=marker.group(2) if marker else "",
                line=before.count("\n") + 1,
            )
        )
    return [b for b in found if lang is None or b.lang == lang]


def command_lines(code: str) -> list[list[str]]:
    """Every `sloshid ...` / `python3 -m sloshid ...` invocation in a bash block, split into arguments (the words
    after `sloshid`); comments, redirections and the other commands of a `&&` / `;` chain are left out."""
    found = []
    text = code.replace("\\\n", " ")
    for line in text.splitlines():
        for part in re.split(r"&&|;", line.split("#")[0]):
            words = shlex.split(part.split(">")[0])
            for start in range(len(words)):
                if words[start].endswith("sloshid") and start + 1 < len(words) and words[start + 1] in COMMANDS:
                    found.append(words[start + 1 :])
    return found
