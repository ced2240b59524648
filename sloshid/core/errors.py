"""The exception types for mistakes a user can cause; the CLI turns them into one sentence."""

from __future__ import annotations

import contextlib
import os
import re
import select
import stat
import sys
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import BinaryIO


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


class NothingFound(SettingError):
    """No frame held what a tracker measures; the message ends with `hint`, where to look, which a front-end that can
    draw a picture of the video's first frame replaces (`with_hint`)."""

    def __init__(self, setting: str, template: str, *others: str, hint: str) -> None:
        super().__init__(setting, template, *others)
        self.hint = hint

    def with_hint(self, hint: str) -> NothingFound:
        """The same error pointing at `hint` instead."""
        return NothingFound(self.setting, self.template.replace(self.hint, hint), *self.others, hint=hint)


class SloshidWarning(UserWarning):
    """A doubt about a result sloshid still returns (a truncated video, a tracker that lost frames, ...). Emitted through
    `warnings.warn`, so that a notebook can filter or capture it, and kept in the result's `warnings` list too."""


def warn(message: str, stacklevel: int = 3) -> None:
    """Emit `message` as a SloshidWarning (stacklevel 3: pointing at the caller of the library function that warns)."""
    warnings.warn(message, SloshidWarning, stacklevel=stacklevel)


SETTING_IN_TEXT = re.compile(r"`([a-z][a-z0-9_]*)`")
"""How a message outside an error names a setting: in backticks, as the library knows it (`window_s`)."""


def rename_settings(text: str, rename: Callable[[str], str | None]) -> str:
    """`text` with each setting named in backticks re-worded by the front-end's `rename` (the CLI gives its option);
    a name `rename` does not know (None) stays as it is."""
    return SETTING_IN_TEXT.sub(lambda m: rename(m.group(1)) or m.group(0), text)


SMALL_FILE_BYTES = 64 * 2**20
"""Largest settings file (TOML scenario, pipeline or batch table; JSON parameters) read: a thousand times any real
one, so that /dev/zero or a mistaken video given as one is refused before memory runs out."""


def input_file(path: str | os.PathLike, what: str, max_bytes: int | None = None) -> Path:
    """`path` as a Path when it names a file (or a pipe) that can be read, else the one-sentence UserError (missing, a
    folder, a device, unreadable, over `max_bytes`), naming it as `what` ("parameter file", "trajectory file", ...)."""
    p = Path(path)
    if p.is_dir():
        raise UserError(f"{what} {p} is a folder, not a file.")
    if not p.exists():  # a pipe (`<(cat x.csv)`, /dev/stdin) exists without being a regular file: it is read
        raise UserError(f"{what} {p} does not exist.")
    if not os.access(p, os.R_OK):
        raise UserError(f"{what} {p} cannot be read (permission denied).")
    mode = p.stat().st_mode
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) or stat.S_ISSOCK(mode):
        raise UserError(f"{what} {p} is a device or socket, not a file.")
    if stat.S_ISREG(mode) and max_bytes is not None and p.stat().st_size > max_bytes:
        raise UserError(
            f"{what} {p} is {p.stat().st_size / 2**20:.1f} MB, more than such a file can be; is it the right file?"
        )
    return p


PIPE_WAIT_NOTE_S = 3.0
"""Seconds an input pipe may stay silent before a line on stderr says what is waited for."""


def open_input(p: Path) -> BinaryIO:
    """`p` opened for reading in binary. A pipe (a named FIFO, `<(...)`) is opened without blocking, so that a FIFO
    with no writer cannot hang the open unseen: its first data or its writer's end is waited for with a line on stderr
    after PIPE_WAIT_NOTE_S (Ctrl-C stops), then it is read from this one descriptor, so that nothing a quick writer
    wrote and closed is lost (a second open of a FIFO whose writer has gone would wait for a new one)."""
    if not stat.S_ISFIFO(p.stat().st_mode) or not hasattr(select, "poll"):
        return open(p, "rb")
    fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
    try:
        poller = select.poll()
        poller.register(fd, select.POLLIN | select.POLLHUP)
        waited, told = 0.0, False
        while not poller.poll(100):  # a FIFO opened so reports no hang-up before its first writer (Linux)
            waited += 0.1
            if not told and waited >= PIPE_WAIT_NOTE_S:
                print(
                    f"sloshid: waiting for data on the pipe {p}: nothing has written to it yet (Ctrl-C to stop).",
                    file=sys.stderr,
                    flush=True,
                )
                told = True
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


_pipes_read: dict[str, bytes] | None = None
"""What each pipe gave (by path) while `pipes_read_once` is active: a pipe gives its data once, and a command reads its
parameter file in several steps. Outside it (the library in a notebook) a pipe is read afresh each time, so that a
FIFO written again is not answered from memory."""


@contextlib.contextmanager
def pipes_read_once() -> Iterator[None]:
    """Within this context (one command), `read_input` reads each pipe once and gives its bytes again when asked."""
    global _pipes_read
    before, _pipes_read = _pipes_read, {}
    try:
        yield
    finally:
        _pipes_read = before


def read_input(path: str | os.PathLike, what: str, max_bytes: int) -> bytes:
    """The bytes of the input file `path` (checked as `input_file` does), at most `max_bytes`: a pipe, whose size is
    known only once read, is refused as soon as it gives more."""
    p = input_file(path, what, max_bytes)
    if _pipes_read is not None and str(p) in _pipes_read:
        return _pipes_read[str(p)]
    with open_input(p) as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise UserError(f"{what} {p} gives more than {max_bytes / 2**20:.0f} MB, more than such a file can be.")
    if _pipes_read is not None and not stat.S_ISREG(p.stat().st_mode):
        _pipes_read[str(p)] = data
    return data
