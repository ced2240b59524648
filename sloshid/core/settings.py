"""Typed settings from TOML/dict tables: unknown keys rejected with a "did you mean", types checked before use."""

from __future__ import annotations

import ast
import dataclasses
import difflib
import functools
import inspect
import itertools
import math
import numbers
import sys
import textwrap
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

from sloshid.core.errors import SMALL_FILE_BYTES, SettingError, UserError, read_input

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised only on Python 3.10
    import tomli as tomllib

T = TypeVar("T")


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, turning a missing, outsized or malformed file into a one-sentence UserError."""
    try:
        raw = read_input(path, "TOML file", SMALL_FILE_BYTES)
        return tomllib.loads(raw.decode("utf-8-sig"))  # a UTF-8 byte-order mark (Windows editors) is accepted
    except (tomllib.TOMLDecodeError, UnicodeDecodeError, ValueError) as exc:  # ValueError: a 5,000-digit number
        raise UserError(f"{path} is not valid TOML ({exc}).") from None
    except RecursionError:
        raise UserError(f"{path} nests arrays or tables too deeply to be a settings file.") from None


def did_you_mean(word: str, choices: typing.Iterable[str]) -> str:
    """' (did you mean X?)' for the closest choice (one that differs only in case first, then one with the same
    letters in another order: 'zdv' is 'zvd' mistyped, not 'zv'), or '' when nothing is close."""
    choices = list(choices)
    same = [c for c in choices if c.lower() == word.lower()]
    swapped = [c for c in choices if sorted(c.lower()) == sorted(word.lower())]
    close = same or swapped or difflib.get_close_matches(word, choices, n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _check(value: Any, tp: Any, where: str) -> Any:
    """Coerce `value` to annotation `tp` (int->float, lists to tuples), or raise a UserError naming `where`."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _check(value, arg, where)
            except UserError as exc:
                errors.append(str(exc))
        raise UserError(errors[0] if errors else f"{where} has an invalid value {value!r}.")
    if origin is typing.Literal:
        if value not in args:
            raise UserError(f"{where} must be one of {', '.join(map(repr, args))}, got {value!r}.")
        return value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise UserError(f"{where} must be a table, got {value!r}.")
        return from_dict(typing.cast(Any, tp), value, where)
    if origin in (tuple, list):
        if not isinstance(value, (list, tuple)):
            raise UserError(f"{where} must be a list, got {value!r}.")
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise UserError(f"{where} must have {len(args)} entries, got {len(value)}.")
            items = [_check(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args))]
        else:
            inner = args[0] if args else Any
            items = [_check(v, inner, f"{where}[{i}]") for i, v in enumerate(value)]
        return tuple(items) if origin is tuple else items
    if tp is float:  # NumPy's scalars too (numbers.Real): a mass taken from an array is a number like any other
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise UserError(f"{where} must be a number, got {value!r}.")
        if value != value:  # TOML's nan: every comparison with it is False, so range checks would let it through
            raise UserError(f"{where} is nan; give a number.")
        if abs(value) == math.inf:  # TOML's inf: a start at infinity "needed at least inf s"
            raise UserError(f"{where} is infinite; give a finite number.")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise UserError(f"{where} must be a whole number, got {value!r}.")
        return int(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise UserError(f"{where} must be true or false, got {value!r}.")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise UserError(f"{where} must be a string, got {value!r}.")
        return value
    if tp is Path:
        if not isinstance(value, str):
            raise UserError(f"{where} must be a path string, got {value!r}.")
        return Path(value)
    return value


def from_dict(cls: type[T], data: dict[str, Any], where: str = "") -> T:
    """Build dataclass `cls` from `data`: unknown keys rejected with a suggestion, missing required keys named.

    `where` is the table's name in messages, e.g. "[limits]". Runs the dataclass's own __post_init__
    checks afterwards, so range checks live with the field definitions.
    """
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(typing.cast(Any, cls)) if f.init}
    prefix = f"{where}." if where else ""
    for key in data:
        if key not in fields:
            raise UserError(f"unknown key '{prefix}{key}'{did_you_mean(key, fields)}.")
    kwargs = {}
    for name, field in fields.items():
        if name in data:
            kwargs[name] = _check(data[name], hints[name], f"{prefix}{name}")
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise UserError(f"missing required key '{prefix}{name}'.")
    try:
        return cls(**kwargs)
    except SettingError as exc:  # the library names its setting; here it is a key of this table
        raise UserError(str(exc.named(lambda setting: f"{prefix}{setting}"))) from None


MAX_GEOMETRY_M = 10.0
"""Largest container size taken (m): a value in millimetres (50 for 50 mm) is refused."""
MIN_GEOMETRY_M = 0.001
"""Smallest container size taken (m): a millimetre; a value below it is a slip (1e-9 gave wall heights in nanometres)."""


def check_in_metres(key: str, value: float | None, example: str = "0.05 for 50 mm") -> None:
    """Refuse a container size (`key`: a radius, a diameter, a fill height; `example`: how to write one) that is not
    a number of metres between MIN_GEOMETRY_M and MAX_GEOMETRY_M: one typed in millimetres made wall heights a
    thousandfold too high. None is not given."""
    if value is None:
        return
    if math.isnan(value) or value == math.inf:
        raise SettingError(key, f"{{name}} must be a finite number of metres ({example}), got {value:g}.")
    if not value > 0:
        raise SettingError(key, f"{{name}} must be positive (m), got {value:g}.")
    if value > MAX_GEOMETRY_M:
        raise SettingError(
            key,
            f"{{name}} must be in metres, at most {MAX_GEOMETRY_M:g} ({example}), got {value:g}: is it in millimetres?",
        )
    if value < MIN_GEOMETRY_M:
        raise SettingError(key, f"{{name}} must be in metres, at least {MIN_GEOMETRY_M:g} ({example}), got {value:g}.")


MAX_AXIS_OFFSET_M = 3.0
"""Largest distance (either way, m) taken from a pose log's point up the container axis to the liquid's surface: the
point is the arm's flange or tool centre, and no tool and container a robot carries reach 3 m; 1e9 (or millimetres,
78 for 78 mm) made accelerations of billions of m/s2 that were blamed on the pose log."""


def check_axis_offset(key: str, value: float | None) -> None:
    """Refuse an axis offset (`key`) that is not a number of metres within MAX_AXIS_OFFSET_M of the logged point (a
    negative one puts the surface below it). None is not given."""
    if value is not None and not abs(value) <= MAX_AXIS_OFFSET_M:  # a NaN fails it too
        raise SettingError(
            key,
            f"{{name}} must be a distance in metres from -{MAX_AXIS_OFFSET_M:g} to {MAX_AXIS_OFFSET_M:g} (the logged "
            f"point to the liquid's surface along the container's axis, e.g. 0.078 for 78 mm), got {value:g}.",
        )


def setting_field(
    default: Any = dataclasses.MISSING,
    *,
    default_factory: Any = dataclasses.MISSING,
    unit: str | None = None,
    option: str | None = None,
    metavar: str | None = None,
    group: str | None = None,
    cli: bool = True,
    separator: str | None = None,
) -> Any:
    """A settings dataclass field with what a front-end needs besides its type, default (or `default_factory`, for a
    list) and attribute docstring (the help text): its `unit`, its command-line `option` when not the field's name with
    hyphens (written without the dashes: the library never spells a flag), the value's `metavar`, the help `group`,
    whether it is on the command line at all (`cli`) and, for a tuple, the `separator` its values are typed with on
    the command line (default a comma). The field's name is its TOML key and its Python keyword."""
    metadata = {"unit": unit, "option": option, "metavar": metavar, "group": group, "cli": cli, "separator": separator}
    kept = {k: v for k, v in metadata.items() if v is not None}
    if default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=default_factory, metadata=kept)
    return dataclasses.field(default=default, metadata=kept)


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """Each dataclass field's attribute docstring (the string under it), inherited ones too, on one line: the one help
    text of a setting, which the settings reference, the command line's help and the API's docstrings all show."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if klass is object or not dataclasses.is_dataclass(klass):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError):  # no source (a frozen application): no help text rather than a failure
            continue
        body = typing.cast(ast.ClassDef, tree.body[0]).body
        for node, after in itertools.pairwise(body):
            if (
                isinstance(node, ast.AnnAssign)
                and isinstance(node.target, ast.Name)
                and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)
            ):
                docs[node.target.id] = " ".join(after.value.value.split())
    return docs


def init_fields(cls: type) -> list[dataclasses.Field]:
    """The fields of settings class `cls` a caller may set (those of its __init__)."""
    return [f for f in dataclasses.fields(typing.cast(Any, cls)) if f.init]
