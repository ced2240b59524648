"""Check every output of a command before any work starts, so that no output replaces an input or another output
of the same run, a report folder only ever gets sloshid's own index.html, and an unwritable path fails at once
with one sentence instead of after minutes of work."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

from sloshid.core.errors import UserError

REPORT_MARK = "<meta name='generator' content='sloshid'>"
"""Written into every sloshid HTML page: an index.html without it is a user's file and is never replaced."""

FIGURE_METADATA = {"Software": "sloshid"}
"""The PNG text chunk of a figure sloshid writes as a file (matplotlib's `savefig(metadata=...)`)."""
FIGURE_MARK = "Software\x00sloshid"
"""FIGURE_METADATA as it stands in the PNG: a figure without it is a user's file and is never replaced."""


def writable_folder(folder: Path, role: str, path: Path) -> None:
    """The folder exists and is writable, or can be created under a writable existing ancestor."""
    probe = folder
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise UserError(f"cannot write {role} {path}: {probe} is a file, not a folder.")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UserError(f"cannot write {role} {path}: the folder {probe} is not writable.")
    # permissions say yes on file systems that refuse new files all the same (/proc, /sys, some mounts): try one
    try:
        fd, name = tempfile.mkstemp(dir=probe, prefix=".sloshid-probe-")
    except OSError as e:
        raise UserError(f"cannot write {role} {path}: the folder {probe} takes no new files ({e.strerror}).") from None
    os.close(fd)
    os.unlink(name)


def _resolved(path: Path) -> Path:
    """`path` with its links followed, or the one-sentence UserError when they go round in a loop."""
    try:
        return path.resolve()
    except (RuntimeError, OSError):  # RuntimeError up to Python 3.12, OSError (ELOOP) after
        raise UserError(f"{path}: its symbolic links go round in a loop.") from None


def holds_mark(path: Path, *marks: str) -> bool:
    """Whether an existing file holds one of `marks` in its first 64 KiB (read as bytes: a PNG's text chunk counts)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(65536).decode("latin-1")
    except OSError:
        return False
    return any(mark in head for mark in marks)


def is_sloshid_page(path: Path) -> bool:
    """Whether an existing HTML file was written by sloshid (its generator mark is in the first kilobytes)."""
    return holds_mark(path, REPORT_MARK, "<p class='meta'>sloshid ")  # the mark, or a page of sloshid 0.1


class Outputs:
    """The outputs of one run, checked as they are declared: each against the inputs and the earlier outputs."""

    def __init__(self, inputs: Iterable[str | os.PathLike] = ()) -> None:
        self.inputs = {_resolved(Path(p)): Path(p) for p in inputs}
        self.claimed: dict[Path, str] = {}

    def _claim(self, path: Path, role: str) -> Path:
        """Refuse a path that is an input or already another output of this run."""
        real = _resolved(path)
        if real in self.inputs:
            raise UserError(f"{role} {path} is also an input of this run; refusing to overwrite it.")
        if real in self.claimed:
            raise UserError(f"{role} and {self.claimed[real]} both name {path}; give them different files.")
        self.claimed[real] = role
        return path

    def file(
        self, path: str | os.PathLike, role: str, suffixes: tuple[str, ...] = (), mark: tuple[str, str] | None = None
    ) -> Path:
        """A file output: right suffix, not a folder, not an input or another output, in a writable folder.
        `mark` = (what sloshid's own file holds, how to proceed) for a file whose name sloshid chose (TRAJ.json beside
        TRAJ.csv): one already there is replaced only when it holds the mark; a user's file is refused."""
        p = Path(path)
        if suffixes and p.suffix.lower() not in suffixes:
            raise UserError(f"{role} {p} must end in {' or '.join(suffixes)}.")
        if p.is_dir():
            raise UserError(f"{role} {p} is a folder; give a file name.")
        if mark is not None and p.is_file() and not holds_mark(p, mark[0]):
            raise UserError(f"{role} {p} is already there and sloshid did not write it; {mark[1]}.")
        if p.exists() and not os.access(p, os.W_OK):
            raise UserError(f"cannot write {role} {p}: the file is read-only.")
        writable_folder(p.parent, role, p)
        return self._claim(p, role)

    def report_dir(self, path: str | os.PathLike, role: str) -> Path:
        """A report folder: sloshid writes only its index.html there, and never over a page it did not write."""
        p = Path(path)
        if (p.exists() and not p.is_dir()) or p.suffix.lower() in (".html", ".htm"):
            raise UserError(f"{role} takes a directory (index.html is written inside it), but {p} names a file.")
        index = p / "index.html"
        if index.exists() and not is_sloshid_page(index):
            raise UserError(
                f"{role} {p} already holds an index.html that sloshid did not write; choose another folder."
            )
        writable_folder(p, role, index)
        self._claim(p, role)  # the folder's own name too: `-o x.json --report x.json` would make x.json a folder
        self._claim(index, role)
        return p
