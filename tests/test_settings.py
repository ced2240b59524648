"""One source of truth for each setting: every field of a settings class has its help text (attribute docstring) and,
where it has one, its unit; it is an option of its command (made from the field, its default the field's own) and a
key of its TOML table; an unknown keyword or key is refused (as python-control's kwargs_test.py checks)."""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import re
from pathlib import Path

import pytest

import sloshid
from sloshid.cli.app import COMMANDS as ALL_COMMANDS
from sloshid.cli.app import build_parser, main
from sloshid.comparison.compare import CompareSettings
from sloshid.comparison.feedback import FeedbackSettings
from sloshid.core.errors import UserError
from sloshid.core.parallel import ClusterSettings
from sloshid.core.settings import field_docs, from_dict, init_fields
from sloshid.identification.estimator import IdentSettings
from sloshid.identification.stage import SignalColumns
from sloshid.model.trajectory import RobotLimits
from sloshid.planning import scenario as scenario_module
from sloshid.planning.arm_settings import ArmSettings
from sloshid.planning.path import PathTable
from sloshid.planning.plan_settings import PlanSettings
from sloshid.planning.scenario import (
    Container,
    Limits,
    LiquidTable,
    Move,
    Obstacle,
    RiskSettings,
    SolverSettings,
    Tray,
    TrayContainer,
    scenario_from_dict,
)
from sloshid.synthetic.scene import SynthSettings
from sloshid.tracking.tracker import TrackSettings
from sloshid.validation.iofit import IOSettings
from sloshid.validation.predict import GeometrySettings, PredictSettings
from sloshid.workflow.options import IdentifyOptions, TrackOptions
from sloshid.workflow.pipeline import Pipeline, ReportSettings, RunSettings
from sloshid.workflow.stages import REGISTRY, CompareOptions, PlanOptions

ROOT = Path(__file__).resolve().parents[1]

COMMANDS = [
    ("track", TrackSettings),
    ("identify", IdentSettings),
    ("identify", SignalColumns),
    ("identify", IOSettings),
    ("validate", SignalColumns),
    ("synth", SynthSettings),
    ("predict", GeometrySettings),
    ("predict", PredictSettings),
    ("validate", GeometrySettings),
    ("plan", PlanSettings),
    ("batch", ClusterSettings),
]
"""Each command's settings classes, whose every field is one of its options."""

SOME_FIELDS = [
    ("plan", ArmSettings, ("fit_joints",)),
    ("run", RunSettings, ("output_dir",)),
    ("inspect", TrackSettings, ("float_color",)),
]
"""Settings of a TOML table a command's option overrides: the command, the class and the fields it has options for."""

NOT_SETTINGS = {
    "synth": {"output", "truth"},
    "inspect": {"video", "output", "at", "roi"},
    "track": {"video", "output", "overlay"},
    "identify": {"signals", "output", "report", "trajectory"},
    "plan": {"scenario", "params", "output", "report", "joints", "json"},
    "predict": {"trajectory", "output", "params"},
    "validate": {"trajectory", "measured", "params", "report", "json"},
    "compare": {"scenario", "params", "report", "output", "json"},
    "run": {"pipeline", "quiet"},
    "batch": {"videos", "config", "out"},
}
"""Each command's options that are no setting: its input and output files and how it prints (--json, --quiet); and
inspect's --at and --roi, still written by hand. Every other option is made from a settings field."""

TABLES = [(TrackOptions, TrackSettings), (IdentifyOptions, IdentSettings), (IdentifyOptions, SignalColumns)]
"""Each TOML table (pipeline [track]/[identify], batch config) and the settings classes it holds."""

SCENARIO_TABLES = {
    "move": [Move],
    "path": [PathTable],
    "limits": [Limits],
    "obstacles": [Obstacle],
    "container": [Container],
    "containers": [TrayContainer],
    "tray": [Tray],
    "risk": [RiskSettings],
    "solver": [SolverSettings],
    "liquid": [LiquidTable],
    "robot": [RobotLimits, ArmSettings],
    "compare": [CompareSettings],
}
"""Each table of a scenario TOML and the settings classes whose fields are its keys ([compare.feedback]: the
FeedbackSettings of CompareSettings.feedback)."""

PIPELINE_TABLES = {
    "run": RunSettings,
    "report": ReportSettings,
    "track": TrackOptions,
    "identify": IdentifyOptions,
    "plan": PlanOptions,
    "compare": CompareOptions,
}
"""Each table of a pipeline TOML and its settings class."""

UNITS = [
    ("_ns_per_m", "N s/m"),
    ("_per_m", None),
    ("_rad_s3", "rad/s^3"),
    ("_rad_s2", "rad/s^2"),
    ("_rad_s", "rad/s"),
    ("_deg_s", "deg/s"),
    ("_m_s3", "m/s^3"),
    ("_m_s2", "m/s^2"),
    ("_m_s", "m/s"),
    ("_percent", "%"),
    ("_deg", "deg"),
    ("_hz", "Hz"),
    ("_kg", "kg"),
    ("_mm", "mm"),
    ("_px", "px"),
    ("_s", "s"),
    ("_m", "m"),
]
"""A field name's unit suffix and the unit it must declare (None: any unit, but one); the longer suffix first."""

TOML_CLASSES = [
    *(cls for classes in SCENARIO_TABLES.values() for cls in classes),
    FeedbackSettings,
    *PIPELINE_TABLES.values(),
]
CLASSES = sorted(
    {cls for _, cls in COMMANDS} | {cls for _, cls, _ in SOME_FIELDS} | set(TOML_CLASSES), key=lambda c: c.__name__
)


def _fields(cls):
    return [pytest.param(cls, f, id=f"{cls.__name__}.{f.name}") for f in init_fields(cls)]


def _command(name: str) -> argparse.ArgumentParser:
    parser = build_parser(only=name)
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]


@pytest.mark.parametrize("cls, field", [p for cls in CLASSES for p in _fields(cls)])
def test_every_field_has_help_and_its_unit(cls, field):
    assert field_docs(cls).get(field.name, "").strip(), f"{cls.__name__}.{field.name} has no docstring"
    for suffix, unit in UNITS:
        if field.name.endswith(suffix):
            assert field.metadata.get("unit"), f"{cls.__name__}.{field.name} names a unit but declares none"
            assert unit is None or field.metadata["unit"] == unit, (field.name, field.metadata["unit"])
            break


OPTION_CASES = [(c, k, None) for c, k in COMMANDS] + SOME_FIELDS


@pytest.mark.parametrize("command, cls, names", OPTION_CASES, ids=[f"{c}-{k.__name__}" for c, k, _ in OPTION_CASES])
def test_every_field_is_an_option_made_from_it(command, cls, names):
    actions = {a.dest: a for a in _command(command)._actions}
    for field in init_fields(cls):
        if names is not None and field.name not in names:
            continue
        assert field.name in actions, f"sloshid {command} has no option for {cls.__name__}.{field.name}"
        action = actions[field.name]
        assert getattr(action, "setting", None) == (cls, field.name), (command, field.name)  # made by add_settings
        # the default is the dataclass's alone: the option gives None when not typed
        assert action.default is None, (command, field.name, action.default)
        help_text = action.help or ""
        assert field_docs(cls)[field.name].split()[0].lower() in help_text.lower(), (command, field.name)
        if field.metadata.get("unit"):
            assert field.metadata["unit"].replace("%", "percent") in help_text, (command, field.name)


@pytest.mark.parametrize("command", ["track", "synth"])
def test_the_float_colour_help_names_every_preset(command):
    # track's listed six of the seven (not dark); synth's pointed at sloshid.video.colors.PRESETS, a Python name
    from sloshid.video.colors import PRESETS

    action = next(a for a in _command(command)._actions if a.dest == "float_color")
    assert all(name in action.help for name in PRESETS), action.help
    assert "sloshid." not in action.help


@pytest.mark.parametrize("command", ["track", "inspect", "synth"])
def test_no_option_help_names_a_python_function(command):
    # track --fov-deg's help named `perspective_deg` and `lens_from_rest`, functions no command-line user can look up;
    # settings named in backticks are re-worded as their options, so a backtick left is such a name
    for action in _command(command)._actions:
        assert "`" not in (action.help or ""), (command, action.dest, action.help)


def test_the_help_shows_the_settings_default():
    # --min-fit's 15 % is written once, in IdentSettings, and the help reads it from there
    help_text = _command("identify").format_help()
    assert f"default {IdentSettings.min_fit_percent:g}" in " ".join(help_text.split())


@pytest.mark.parametrize("table, cls", TABLES, ids=[f"{t.__name__}-{c.__name__}" for t, c in TABLES])
def test_every_field_is_a_key_of_its_toml_table(table, cls):
    keys = {f.name for f in init_fields(table)}
    for field in init_fields(cls):
        assert field.name in keys
        if field.default is not dataclasses.MISSING and field.default is not None:
            value = list(field.default) if isinstance(field.default, tuple) else field.default
            assert getattr(from_dict(table, {field.name: value}), field.name) == field.default


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_an_unknown_key_is_refused_with_a_suggestion(cls):
    name = init_fields(cls)[0].name
    with pytest.raises(UserError, match=f"unknown key '{name}x'.*did you mean '{name}'"):
        from_dict(cls, {name + "x": 1})


def test_an_unknown_keyword_of_the_api_is_refused():
    with pytest.raises(UserError, match="did you mean 'reference'"):
        sloshid.track("video.mp4", refernce="container")
    with pytest.raises(UserError, match="did you mean 'mass_kg'"):
        sloshid.identify("signal.csv", mass_kgs=0.5)
    with pytest.raises(UserError, match="unknown key 'colour'"):
        sloshid.track("video.mp4", colour="red")


def test_the_api_takes_a_settings_object_or_keywords_not_both():
    with pytest.raises(UserError, match="not both"):
        sloshid.track("video.mp4", sloshid.TrackSettings(reference="container"), target="surface")
    with pytest.raises(UserError, match="must be a TrackSettings"):
        sloshid.track("video.mp4", sloshid.IdentSettings())


def test_the_settings_classes_are_exported():
    for cls in (
        TrackSettings,
        IdentSettings,
        SignalColumns,
        IOSettings,
        GeometrySettings,
        SynthSettings,
        PredictSettings,
        PlanSettings,
        ClusterSettings,
    ):
        assert getattr(sloshid, cls.__name__) is cls
        assert cls.__name__ in sloshid.__all__


def test_an_unknown_option_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["track", "video.mp4", "-o", str(tmp_path / "a.csv"), "--refernce", "container"])
    assert exc.value.code == 2 and "unrecognized arguments: --refernce" in capsys.readouterr().err


def _dests(command: str) -> dict[str, argparse.Action]:
    return {a.dest: a for a in _command(command)._actions if a.dest != "help"}


@pytest.mark.parametrize("command", list(ALL_COMMANDS))
def test_every_option_is_a_settings_field_or_a_file(command):
    # no setting is written by hand: an option that is neither an input or output file (nor --json, --quiet) must be
    # one of the command's settings fields, made by add_settings (default None: the dataclass's own applies)
    actions = _dests(command)
    fields = {f.name for c, cls in COMMANDS if c == command for f in init_fields(cls)}
    fields |= {name for c, _, names in SOME_FIELDS if c == command for name in names}
    assert NOT_SETTINGS[command] <= set(actions), f"NOT_SETTINGS[{command!r}] names an option that is gone"
    for dest, action in actions.items():
        if dest not in NOT_SETTINGS[command]:
            assert dest in fields, f"sloshid {command} {max(action.option_strings, key=len)} is written by hand"
            assert action.default is None, (command, dest)


WRONG = {"not_a_key_of_it": 1}
"""A value no field takes: a table where a number, string, list or switch belongs (a nested table: an unknown key)."""


BASE = {"move": {"start": [0.0, 0.0, 0.3], "goal": [0.3, 0.0, 0.3]}}
PATH = {"waypoints": [[0.0, 0.0, 0.3], [0.2, 0.0, 0.3], [0.3, 0.1, 0.3]]}


def _scenario_with(table: str, entries: dict) -> None:
    """Load a small scenario whose `table` holds `entries` (the compare table as `sloshid compare` reads it)."""
    data = {**BASE}
    if table == "path":
        data = {"path": {**PATH, **entries}}
    elif table == "move":
        data = {"move": {**BASE["move"], **entries}}
    elif table in ("obstacles", "containers"):
        data[table] = [entries]
    else:
        data[table] = entries
    scenario = scenario_from_dict(data, "scenario.toml")
    if table == "compare":
        from_dict(CompareSettings, scenario.compare, "[compare]")


def test_the_scenario_tables_are_the_listed_ones():
    assert set(SCENARIO_TABLES) == set(scenario_module._TABLES)
    assert set(PIPELINE_TABLES) == {"run", "report", *REGISTRY}
    for name, stage in REGISTRY.items():
        assert stage.settings_type is PIPELINE_TABLES[name]


@pytest.mark.parametrize(
    "table, cls", [(t, c) for t, cs in SCENARIO_TABLES.items() for c in cs], ids=lambda v: getattr(v, "__name__", v)
)
def test_every_field_is_a_key_of_its_scenario_table(table, cls):
    for field in init_fields(cls):
        with pytest.raises(UserError) as exc:
            _scenario_with(table, {field.name: WRONG})
        assert "unknown key" not in str(exc.value) or "not_a_key_of_it" in str(exc.value), (table, field.name)
    with pytest.raises(UserError, match=r"unknown key '.*\.nosuchkey'"):
        _scenario_with(table, {"nosuchkey": 1})


def test_the_feedback_table_of_compare_takes_every_feedback_field():
    for field in init_fields(FeedbackSettings):
        with pytest.raises(UserError, match=re.escape(f"[compare].feedback.{field.name} ")):
            _scenario_with("compare", {"feedback": {field.name: WRONG}})
    with pytest.raises(UserError, match=r"unknown key '\[compare\]\.feedback\.nosuchkey'"):
        _scenario_with("compare", {"feedback": {"nosuchkey": 1}})


@pytest.mark.parametrize("table", list(PIPELINE_TABLES))
def test_every_field_is_a_key_of_its_pipeline_table(table, tmp_path):
    pipe = tmp_path / "pipe.toml"
    for field in init_fields(PIPELINE_TABLES[table]):
        pipe.write_text(f"[{table}]\n{field.name} = {{ not_a_key_of_it = 1 }}\n")
        with pytest.raises(UserError) as exc:
            Pipeline.load(pipe, REGISTRY)
        assert "unknown key" not in str(exc.value) or "not_a_key_of_it" in str(exc.value), (table, field.name)
    pipe.write_text(f"[{table}]\nnosuchkey = 1\n")
    with pytest.raises(UserError, match=rf"unknown key '\[{table}\]\.nosuchkey'"):
        Pipeline.load(pipe, REGISTRY)


def _hook():
    spec = importlib.util.spec_from_file_location("sloshid_docs_hook", ROOT / "docs" / "hooks" / "generated.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_settings_reference_lists_every_field():
    # docs/reference/settings.md's tables are generated from these classes: each of them, each field, with its unit
    hook = _hook()
    listed = set(hook.SETTINGS)
    tables = hook.settings_tables()
    for cls in CLASSES:
        assert f"{cls.__module__}.{cls.__qualname__}" in listed, cls.__name__
        section = tables.split(f"### {cls.__name__}\n", 1)[1].split("\n### ", 1)[0]
        for field in init_fields(cls):
            if field.name in hook.inherited(cls):
                continue
            row = next((r for r in section.splitlines() if r.startswith(f"| `{field.name}` |")), None)
            assert row is not None, f"{cls.__name__}.{field.name}"
            assert field.metadata.get("unit", "") in row
