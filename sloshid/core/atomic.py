"""Atomic outputs: write to a temporary sibling, rename on success, so a failed run leaves nothing half-written.

A file-system error on the way (read-only folder, disk full, a parent that is a file) becomes one UserError that
names the output, and the temporary file is removed."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from sloshid.core.errors import UserError


def _usual_mode(path: Path, directory: bool) -> None:
    """Give a temp file or folder (mkstemp/mkdtemp make them owner-only) the permissions of a normal output."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, (0o777 if directory else 0o666) & ~umask)


def _write_error(target: Path, exc: OSError) -> UserError:
    """One sentence for a failed write."""
    return UserError(f"could not write {target}: {exc.strerror or exc}.")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside `path` (same suffix); it replaces `path` only if the block succeeds."""
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".part{target.suffix}", dir=target.parent)
        os.close(fd)
        _usual_mode(Path(tmp), directory=False)
    except OSError as exc:
        raise _write_error(target, exc) from None
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    except OSError as exc:
        raise _write_error(target, exc) from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json(path: str | os.PathLike, doc: Any) -> None:
    """Write a JSON document atomically; non-finite numbers are refused (JSON has none), nothing is written then."""
    try:
        text = json.dumps(doc, indent=2, allow_nan=False)
    except ValueError:
        raise UserError(f"the results hold non-finite numbers; {path} was not written.") from None
    write_text(path, text + "\n")


@contextlib.contextmanager
def atomic_dir(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary directory beside `path`; it becomes `path` only on success. For folders that sloshid owns
    whole (a pipeline's run and cache folders); an existing `path` is refused, never replaced."""
    target = Path(path)
    if target.exists():
        raise UserError(f"{target} already exists; sloshid does not replace a folder it did not just create.")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent))
        _usual_mode(tmp, directory=True)
    except OSError as exc:
        raise _write_error(target, exc) from None
    try:
        yield tmp
        os.replace(tmp, target)
    except OSError as exc:
        raise _write_error(target, exc) from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
