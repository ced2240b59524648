"""One source of truth for each setting: every field of a settings class has its help text (attribute docstring) and,
where it has one, its unit; it is an option of its command (made from the field, its default the field's own) and a
key of its TOML table; an unknown keyword or key is refused (as python-control's kwargs_test.py checks)."""

from __future__ import annotations

import argparse
import dataclasses

import pytest

import sloshid
from sloshid.cli.app import build_parser, main
from sloshid.core.errors import UserError
from sloshid.core.settings import field_docs, from_dict, init_fields
from sloshid.identification.estimator import IdentSettings
from sloshid.identification.stage import SignalColumns
from sloshid.synthetic.scene import SynthSettings
from sloshid.tracking.tracker import TrackSettings
from sloshid.validation.iofit import IOSettings
from sloshid.validation.predict import GeometrySettings
from sloshid.workflow.options import IdentifyOptions, TrackOptions

COMMANDS = [
    ("track", TrackSettings),
    ("identify", IdentSettings),
    ("identify", SignalColumns),
    ("identify", IOSettings),
    ("validate", SignalColumns),
    ("synth", SynthSettings),
    ("predict", GeometrySettings),
    ("validate", GeometrySettings),
]
"""Each command's settings classes, whose every field is one of its options."""

TABLES = [(TrackOptions, TrackSettings), (IdentifyOptions, IdentSettings), (IdentifyOptions, SignalColumns)]
"""Each TOML table (pipeline [track]/[identify], batch config) and the settings classes it holds."""

UNITS = [
    ("_ns_per_m", "N s/m"),
    ("_per_m", None),
    ("_m_s2", "m/s^2"),
    ("_percent", "%"),
    ("_deg", "deg"),
    ("_hz", "Hz"),
    ("_kg", "kg"),
    ("_px", "px"),
    ("_s", "s"),
    ("_m", "m"),
]
"""A field name's unit suffix and the unit it must declare (None: any unit, but one)."""

CLASSES = sorted({cls for _, cls in COMMANDS}, key=lambda c: c.__name__)


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


@pytest.mark.parametrize("command, cls", COMMANDS, ids=[f"{c}-{k.__name__}" for c, k in COMMANDS])
def test_every_field_is_an_option_made_from_it(command, cls):
    actions = {a.dest: a for a in _command(command)._actions}
    for field in init_fields(cls):
        assert field.name in actions, f"sloshid {command} has no option for {cls.__name__}.{field.name}"
        action = actions[field.name]
        # the default is the dataclass's alone: the option gives None when not typed
        assert action.default is None, (command, field.name, action.default)
        help_text = action.help or ""
        assert field_docs(cls)[field.name].split()[0].lower() in help_text.lower(), (command, field.name)
        if field.metadata.get("unit"):
            assert field.metadata["unit"].replace("%", "percent") in help_text, (command, field.name)


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


@pytest.mark.parametrize("cls", [TrackOptions, IdentifyOptions, IdentSettings, SynthSettings])
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
    for cls in (TrackSettings, IdentSettings, SignalColumns, IOSettings, GeometrySettings, SynthSettings):
        assert getattr(sloshid, cls.__name__) is cls
        assert cls.__name__ in sloshid.__all__


def test_an_unknown_option_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["track", "video.mp4", "-o", str(tmp_path / "a.csv"), "--refernce", "container"])
    assert exc.value.code == 2 and "unrecognized arguments: --refernce" in capsys.readouterr().err
