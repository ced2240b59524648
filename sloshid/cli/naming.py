"""How the command line names the library's settings: the library writes `mass_kg`, the user typed --mass. Every
message a command prints (errors, warnings, summaries) passes through here on its way out."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from sloshid.core.errors import rename_settings


def flag_for(setting: str, options: dict[str, str]) -> str:
    """The command-line name of a library setting: the command's option that fills it (`options_of`), else
    --setting-with-hyphens."""
    return options.get(setting, "--" + setting.replace("_", "-"))


def options_of(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each option's destination -> its longest spelling (`roi` -> --roi), for naming settings in messages."""
    return {a.dest: max(a.option_strings, key=len) for a in parser._actions if a.option_strings}


def option_namer(args: argparse.Namespace | None, also: dict[str, str] | None = None) -> Callable[[str], str | None]:
    """A setting's option in the command `args` came from (the option that fills it, else one of `also`: another
    command's options the text speaks of), or None (the message keeps the library's name)."""
    options: dict[str, str] = {**(also or {}), **getattr(args, "_options", {})}
    return options.get


def as_typed(text: str, args: argparse.Namespace | None, also: dict[str, str] | None = None) -> str:
    """`text` with the settings it names in backticks (`window_s`) re-worded as the options the user types."""
    return rename_settings(text, option_namer(args, also))
