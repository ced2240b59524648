"""MkDocs hook: the pages' generated parts, made from the code at build time so that they cannot drift from it.

- `<!-- generated: cli -->` becomes every command's `--help`, from `sloshid.cli.app.build_parser`;
- `<!-- generated: settings -->` becomes a table per settings class: each field's key (TOML and Python keyword),
  command-line option, unit and default, read from the field itself as the command line reads it;
- the benchmarks' pictures (`reports/benchmarks/*.png`) are served beside the benchmark pages that include
  their tables (`--8<--` snippets), so the tables' own picture links resolve.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = ROOT / "reports" / "benchmarks"
HELP_WIDTH = "100"


def command_help() -> dict[str, str]:
    """`sloshid COMMAND --help` of every command, in the order `sloshid --help` lists them."""
    from sloshid.cli.app import COMMANDS, build_parser

    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_WIDTH  # argparse wraps to the terminal: a fixed width keeps the page stable
    try:
        texts = {"sloshid": build_parser().format_help()}
        for name in COMMANDS:
            parser = build_parser(only=name)
            sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
            texts[name] = sub.choices[name].format_help()
    finally:
        if previous is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = previous
    return texts


def cli_reference() -> str:
    """The command-line reference's body: one section per command with its help as printed."""
    parts = []
    for name, text in command_help().items():
        title = name if name == "sloshid" else f"sloshid {name}"
        parts.append(f"## `{title}`\n\n```text\n{text.rstrip()}\n```\n")
    return "\n".join(parts)


SETTINGS = {
    "sloshid.tracking.tracker.TrackSettings": "`sloshid track`; the pipeline's and batch's `[track]`; `sloshid.track`",
    "sloshid.identification.estimator.IdentSettings": "`sloshid identify`; `[identify]`; `sloshid.identify`",
    "sloshid.identification.stage.SignalColumns": "`sloshid identify` and `validate`; `[identify]`; `sloshid.identify`",
    "sloshid.validation.iofit.IOSettings": "`sloshid identify --trajectory`",
    "sloshid.validation.predict.GeometrySettings": "`sloshid predict` and `sloshid validate`",
    "sloshid.synthetic.scene.SynthSettings": "`sloshid synth`",
}
"""The settings classes whose fields are made into options, and where each is filled."""


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def settings_tables() -> str:
    """One table per class of SETTINGS: key, option, unit, default and help of every field."""
    import dataclasses
    import importlib

    from sloshid.cli.settings_options import option_of
    from sloshid.core.settings import field_docs, init_fields

    parts = []
    for path, where in SETTINGS.items():
        module, name = path.rsplit(".", 1)
        cls = getattr(importlib.import_module(module), name)
        rows = ["| key | option | unit | default | what |", "|---|---|---|---|---|"]
        for field in init_fields(cls):
            default = "" if field.default in (None, dataclasses.MISSING) else f"`{field.default!r}`"
            option = option_of(field)
            rows.append(
                f"| `{field.name}` | {f'`{option}`' if option else ''} | {_cell(field.metadata.get('unit', ''))} | "
                f"{_cell(default)} | {_cell(field_docs(cls)[field.name])} |"
            )
        parts.append(f"### {name}\n\nFilled by {where}.\n\n" + "\n".join(rows) + "\n")
    return "\n".join(parts)


GENERATORS = {"<!-- generated: cli -->": cli_reference, "<!-- generated: settings -->": settings_tables}


def on_page_markdown(markdown: str, page, config, files) -> str:
    for mark, make in GENERATORS.items():
        if mark in markdown:
            markdown = markdown.replace(mark, make())
    return markdown


def on_files(files, config):
    for picture in sorted(BENCHMARKS.glob("*.png")):
        files.append(File.generated(config, f"benchmarks/{picture.name}", abs_src_path=str(picture)))
    return files
