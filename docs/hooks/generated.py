"""MkDocs hook: the pages' generated parts, made from the code at build time so that they cannot drift from it.

- `<!-- generated: cli -->` becomes every command's `--help`, from `sloshid.cli.app.build_parser`;
- `<!-- generated: settings -->` becomes a table per settings class (every command's, every scenario and pipeline
  table's): each field's key (TOML and Python keyword), the command-line options made from it, its unit and default,
  read from the field itself as the command line reads it;
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
    "sloshid.workflow.options.TrackOptions": "the pipeline's and the batch config's `[track]` table, besides every "
    "TrackSettings field",
    "sloshid.identification.estimator.IdentSettings": "`sloshid identify`; `[identify]`; `sloshid.identify`",
    "sloshid.identification.stage.SignalColumns": "`sloshid identify` and `validate`; `[identify]`; `sloshid.identify`",
    "sloshid.workflow.options.IdentifyOptions": "the pipeline's and the batch config's `[identify]` table, besides "
    "every IdentSettings field",
    "sloshid.validation.iofit.IOSettings": "`sloshid identify --trajectory`",
    "sloshid.validation.predict.GeometrySettings": "`sloshid predict` and `sloshid validate`",
    "sloshid.validation.predict.PredictSettings": "`sloshid predict`",
    "sloshid.planning.plan_settings.PlanSettings": "`sloshid plan`; `sloshid.plan`'s `robust`",
    "sloshid.planning.scenario.Move": "the scenario's `[move]`",
    "sloshid.planning.path.PathTable": "the scenario's `[path]` (instead of `[move]`)",
    "sloshid.planning.scenario.Limits": "the scenario's `[limits]`",
    "sloshid.planning.scenario.Obstacle": "the scenario's `[[obstacles]]`, one table per obstacle",
    "sloshid.planning.scenario.Container": "the scenario's `[container]`",
    "sloshid.planning.scenario.TrayContainer": "the scenario's `[[containers]]`, one table per container on a tray",
    "sloshid.planning.scenario.Tray": "the scenario's `[tray]`",
    "sloshid.planning.scenario.RiskSettings": "the scenario's `[risk]`",
    "sloshid.planning.scenario.SolverSettings": "the scenario's `[solver]`",
    "sloshid.planning.scenario.LiquidTable": "the scenario's `[liquid]` (`--params` replaces it)",
    "sloshid.model.trajectory.RobotLimits": "the scenario's `[robot]`: the robot's Cartesian limits",
    "sloshid.planning.arm_settings.ArmSettings": "the scenario's `[robot]`: the arm (`sloshid plan --joints`); "
    "`fit_joints` is also `sloshid plan --fit-joints`",
    "sloshid.comparison.compare.CompareSettings": "the scenario's `[compare]` (`sloshid compare`)",
    "sloshid.comparison.feedback.FeedbackSettings": "the scenario's `[compare.feedback]`",
    "sloshid.workflow.pipeline.RunSettings": "the pipeline's `[run]`; `output_dir` is also `sloshid run --output-dir`",
    "sloshid.workflow.pipeline.ReportSettings": "the pipeline's `[report]`",
    "sloshid.workflow.stages.PlanOptions": "the pipeline's `[plan]`",
    "sloshid.workflow.stages.CompareOptions": "the pipeline's `[compare]`",
    "sloshid.core.parallel.ClusterSettings": "`sloshid batch`",
    "sloshid.synthetic.scene.SynthSettings": "`sloshid synth`",
}
"""Every settings class, with where it is filled: a command's options (made from its fields), a TOML table (its
fields are the keys) and the Python functions' keywords."""


def command_options() -> dict[tuple[type, str], list[str]]:
    """(settings class, field) -> the options made from it, as `sloshid COMMAND --option` (from every command's parser:
    `add_settings` marks each option it makes with the field it fills)."""
    from sloshid.cli.app import COMMANDS, build_parser

    made: dict[tuple[type, str], list[str]] = {}
    for name in COMMANDS:
        parser = build_parser(only=name)
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
        for action in sub._actions:
            if getattr(action, "setting", None) is not None:
                made.setdefault(action.setting, []).append(f"{name} {max(action.option_strings, key=len)}")
    return made


def _class(path: str) -> type:
    import importlib

    module, name = path.rsplit(".", 1)
    return getattr(importlib.import_module(module), name)


def inherited(cls: type) -> set[str]:
    """The fields `cls` takes from a settings class with a table of its own (TrackOptions: TrackSettings's)."""
    import dataclasses

    listed = {_class(path) for path in SETTINGS}
    return {
        f.name
        for base in cls.__mro__[1:]
        if base in listed and dataclasses.is_dataclass(base)
        for f in dataclasses.fields(base)
    }


def _cell(text: str) -> str:
    """`text` in a table cell: its bars escaped, and its angle brackets (`<output_dir>/<name>`), which Markdown would
    take for HTML tags."""
    return text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def _default(field) -> str:
    """The field's default as a table cell: its value, a list's (from its factory), blank for none or a nested table."""
    import dataclasses

    value = field.default
    if field.default_factory is not dataclasses.MISSING:
        value = field.default_factory()
    if value is None or value is dataclasses.MISSING or dataclasses.is_dataclass(value):
        return ""
    return f"`{value!r}`"


def settings_tables() -> str:
    """One table per class of SETTINGS: key, option, unit, default and help of every field (of a class that adds to
    another, the fields it adds)."""
    from sloshid.core.settings import field_docs, init_fields

    options = command_options()
    parts = []
    for path, where in SETTINGS.items():
        cls = _class(path)
        rows = ["| key | option (sloshid ...) | unit | default | what |", "|---|---|---|---|---|"]
        skip = inherited(cls)
        for field in init_fields(cls):
            if field.name in skip:
                continue
            option = ", ".join(f"`{o}`" for o in options.get((cls, field.name), []))
            rows.append(
                f"| `{field.name}` | {option} | {_cell(field.metadata.get('unit', ''))} | "
                f"{_cell(_default(field))} | {_cell(field_docs(cls)[field.name])} |"
            )
        parts.append(f"### {cls.__name__}\n\nFilled by {where}.\n\n" + "\n".join(rows) + "\n")
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
