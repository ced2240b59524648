"""The exception types for mistakes a user can cause; the CLI turns them into one sentence."""

from __future__ import annotations


class UserError(Exception):
    """A bad file, option or request: reported as one sentence on stderr, exit code 2, no traceback."""


class SettingError(UserError):
    """A bad value of one named setting. The message names the setting as the library knows it (`mass_kg`); each
    front-end re-words it with its own name for that setting (`--mass` on the command line, `[identify] mass_kg`
    in a pipeline) through `named()`."""

    def __init__(self, setting: str, template: str) -> None:
        self.setting = setting
        self.template = template
        super().__init__(template.format(name=setting))

    def named(self, name: str) -> SettingError:
        """The same error, with the setting called `name`."""
        err = SettingError(self.setting, self.template)
        err.args = (self.template.format(name=name),)
        return err
