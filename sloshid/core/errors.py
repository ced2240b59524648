"""The exception types for mistakes a user can cause; the CLI turns them into one sentence."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path


class UserError(Exception):
    """A bad file, option or request: reported as one sentence on stderr, exit code 2, no traceback."""


class SettingError(UserError):
    """A bad value of a named setting. The message names settings as the library knows them (`mass_kg`); each
    front-end re-words them with its own names (`--mass` on the command line, `[identify].mass_kg` in a pipeline)
    through `named()`. The template writes the setting at fault as {name} and any other setting it mentions as
    {that_setting}."""

    def __init__(self, setting: str, template: str, *others: str) -> None:
        self.setting = setting
        self.others = others
        self.template = template
        super().__init__(self._render(lambda s: s))

    def _render(self, rename: Callable[[str], str]) -> str:
        # plain replacement, not str.format: the message may quote paths and values that hold braces
        text = self.template.replace("{name}", rename(self.setting))
        for other in self.others:
            text = text.replace("{" + other + "}", rename(other))
        return text

    def named(self, rename: str | Callable[[str], str]) -> SettingError:
        """The same error with every setting renamed (a string renames the one at fault only)."""
        err = SettingError(self.setting, self.template, *self.others)
        fn = (lambda s: rename if s == self.setting else s) if isinstance(rename, str) else rename
        err.args = (self._render(fn),)
        return err


def input_file(path: str | os.PathLike, what: str) -> Path:
    """`path` as a Path when it names a file (or a pipe) that can be read, else the one-sentence UserError (missing, a
    folder, unreadable), naming it as `what` ("parameter file", "trajectory file", ...)."""
    p = Path(path)
    if p.is_dir():
        raise UserError(f"{what} {p} is a folder, not a file.")
    if not p.exists():  # a pipe (`<(cat x.csv)`, /dev/stdin) exists without being a regular file: it is read
        raise UserError(f"{what} {p} does not exist.")
    if not os.access(p, os.R_OK):
        raise UserError(f"{what} {p} cannot be read (permission denied).")
    return p
