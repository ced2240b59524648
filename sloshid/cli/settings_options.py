"""Command-line options made from a settings dataclass: one option per field, named, typed, explained and defaulted by
the field itself (its annotation, default, attribute docstring and `core.settings.setting_field` metadata), so that an option
cannot drift from the setting it fills. A small generator of our own rather than tyro or cyclopts: those build the
whole parser, while sloshid's commands mix settings with inputs and outputs, keep their options' historical names
(`--mass` for `mass_kg`) and argparse's one-line errors, and start in a few milliseconds."""

from __future__ import annotations

import argparse
import dataclasses
import re
import types
import typing
from pathlib import Path
from typing import Any, Literal, TypeVar

from sloshid.core.errors import UserError, rename_settings
from sloshid.core.settings import field_docs, init_fields

T = TypeVar("T")

NUMBER_WORDS = {2: "two", 3: "three", 4: "four"}


def option_of(field: dataclasses.Field) -> str | None:
    """The field's command-line option (`--mass` for mass_kg), or None when it has none; a True-by-default switch is
    turned off with --no-NAME."""
    if not field.metadata.get("cli", True):
        return None
    name = field.metadata.get("option") or field.name.replace("_", "-")
    return f"--no-{name}" if field.default is True else f"--{name}"


def options_of_settings(cls: type) -> dict[str, str]:
    """Field name -> option of every field of `cls` on the command line."""
    return {f.name: o for f in init_fields(cls) if (o := option_of(f))}


def _plain_type(annotation: Any) -> Any:
    """The annotation without its `| None`."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return args[0] if len(args) == 1 else annotation
    return annotation


def comma_values(
    text: str, kind: type | tuple[type, ...], count: int, option: str, metavar: str, separator: str = ","
) -> tuple:
    """`count` `kind`s separated by commas (`0.5,30` for a pair of floats; `kind` may give each value's type, and
    `separator` another mark), or a UserError naming the option."""
    kinds = kind if isinstance(kind, tuple) else (kind,) * count
    parts = text.split(separator)
    try:
        values = tuple(k(v.strip()) for k, v in zip(kinds, parts)) if len(parts) == count else ()
    except ValueError:
        values = ()
    if len(values) != count:
        what = "whole numbers" if all(k is int for k in kinds) else "numbers"
        raise UserError(f"{option} must be {NUMBER_WORDS.get(count, count)} {what} {metavar}, got '{text}'.")
    return values


def _format_default(value: Any) -> str:
    """A default as it would be typed."""
    if isinstance(value, tuple):
        return ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def help_text(field: dataclasses.Field, doc: str, options: dict[str, str]) -> str:
    """The option's help: the field's docstring (settings it names in backticks as their options), its unit and its
    default. A % is written as the word (argparse would need it doubled in the help it formats)."""
    text = rename_settings(doc, options.get)
    if field.default is True:
        text = f"turn off: {text[:1].lower()}{text[1:]}"
    extra = [field.metadata["unit"]] if field.metadata.get("unit") else []
    if not any(field.default is v for v in (None, False, True, dataclasses.MISSING)):
        extra.append(f"default {_format_default(field.default)}")
    if extra:
        text += f" ({'; '.join(extra)})"
    return re.sub(r" ?%", " percent", text).replace("( percent", "(percent")


def _argument(field: dataclasses.Field, annotation: Any, option: str, help: str) -> dict[str, Any]:
    """argparse keywords of one field: typed, with choices for a Literal, a switch for a bool; default None (not given:
    the dataclass's own default applies)."""
    kind = _plain_type(annotation)
    metavar = field.metadata.get("metavar") or option.lstrip("-").replace("-", "_").upper()
    kwargs: dict[str, Any] = {"dest": field.name, "default": None, "help": help}
    if kind is bool:
        return {**kwargs, "action": "store_false" if field.default is True else "store_true"}
    if typing.get_origin(kind) is Literal:
        return {**kwargs, "choices": typing.get_args(kind)}
    if typing.get_origin(kind) is tuple:  # read as text, parsed by given_settings
        return {**kwargs, "metavar": metavar}
    return {**kwargs, "type": kind if kind in (int, float, Path) else str, "metavar": metavar}


def add_settings(
    parser: argparse.ArgumentParser,
    cls: type,
    groups: dict[str, str] | None = None,
    *,
    only: tuple[str, ...] | None = None,
    title: str | None = None,
) -> None:
    """Add one option per field of settings class `cls` (or per field named in `only`) to `parser`; a field whose
    metadata names a group goes into the argument group titled `groups[group]` (made once per title), and with a
    `title` every option goes into the group of that title (a TOML table's settings the command line overrides)."""
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    options = options_of_settings(cls)
    made: dict[str, argparse._ArgumentGroup] = {}
    unknown = set(only or ()) - {f.name for f in init_fields(cls)}
    if unknown:
        raise ValueError(f"{cls.__name__} has no field {', '.join(sorted(unknown))}")
    if title is not None:
        made[title] = parser.add_argument_group(title)
    for field in init_fields(cls):
        option = options.get(field.name)
        if option is None or (only is not None and field.name not in only):
            continue
        group = field.metadata.get("group")
        target: Any = made[title] if title is not None else parser
        if group is not None and groups is not None:
            title = groups[group]
            target = made.get(title) or made.setdefault(title, parser.add_argument_group(title))
        help = help_text(field, docs.get(field.name, ""), options)  # no docstring only where no source was shipped
        action = target.add_argument(option, **_argument(field, hints[field.name], option, help))
        action.setting = (cls, field.name)  # what the settings reference reads (docs/hooks/generated.py)


def given_settings(args: argparse.Namespace, cls: type) -> dict[str, Any]:
    """The fields of `cls` the command line gave (the others keep the dataclass's defaults), a tuple's text parsed."""
    hints = typing.get_type_hints(cls)
    given = {}
    for field in init_fields(cls):
        value = getattr(args, field.name, None)
        kind = _plain_type(hints[field.name])
        if isinstance(value, str) and typing.get_origin(kind) is tuple:
            items = typing.get_args(kind)
            option = option_of(field) or field.name
            metavar, separator = field.metadata.get("metavar", ""), field.metadata.get("separator", ",")
            value = comma_values(value, tuple(items), len(items), option, metavar, separator)
        if value is not None:
            given[field.name] = value
    return given


def settings_from(args: argparse.Namespace, cls: type[T], **more: Any) -> T:
    """Settings class `cls` filled from the options `add_settings` made (and `more`): checked by its own __post_init__,
    whose SettingError names the field, which the command line re-words as the option."""
    return cls(**{**given_settings(args, cls), **more})
