"""Atomic outputs: write to a temporary sibling, rename on success, so a failed run leaves nothing half-written.

A file-system error on the way (read-only folder, disk full, a parent that is a file) becomes one UserError that
names the output, and the temporary file is removed."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import secrets
import shutil
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from sloshid.core.errors import UserError


def temporary_sibling(target: Path, suffix: str) -> Path:
    """A hidden temporary name beside `target`, random (64 bits) so that parallel runs never pick the same one, with
    the writing process's id, so that a later run can tell one left by a killed process (`remove_orphans`).

    The name is chosen before anything is created, so that a `finally` can remove whatever exists under it: an
    interruption (SIGTERM, Ctrl-C) between creating the file and entering a `try` would otherwise leave it behind."""
    return target.parent / f".{target.name}.{writer_tag()}-{secrets.token_hex(8)}{suffix}"


def writer_tag(pid: int | None = None) -> str:
    """`<host>-<pid>` of the writing process (this one by default), the host as 8 hex digits of its name's hash: a
    folder shared by several machines holds the work of processes this one cannot see."""
    host = hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]
    return f"{host}-{os.getpid() if pid is None else pid}"


def _alive(pid: int) -> bool:
    """Whether a process with this id runs (one of another user counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def writer_gone(name: str) -> bool:
    """Whether the `writer_tag` in a temporary or marker name (`.<name>.<tag>-<token>.part`, `.running-<tag>`) is of a
    process of this machine that no longer runs: what it was writing will never be finished (SIGKILL, a power cut).
    Another machine's processes are never judged gone."""
    match = re.search(r"[.-]([0-9a-f]{8})-(\d+)(?:-[0-9a-f]{16})?(?:\.part\b|$)", name)
    if match is None or match.group(1) != writer_tag().split("-")[0]:
        return False
    return not _alive(int(match.group(2)))


def remove_orphans(folder: Path) -> None:
    """Remove the `.part` temporaries in `folder` whose writer was killed before it could remove them."""
    for entry in folder.glob(".*.part*"):
        if writer_gone(entry.name):
            shutil.rmtree(entry, ignore_errors=True) if entry.is_dir() else entry.unlink(missing_ok=True)


def _write_error(target: Path, exc: OSError) -> UserError:
    """One sentence for a failed write."""
    return UserError(f"could not write {target}: {exc.strerror or exc}.")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside `path` (same suffix); it replaces `path` only if the block succeeds."""
    target = Path(path)
    tmp = temporary_sibling(target, f".part{target.suffix}")
    made = missing_top(target.parent)
    done = False
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))  # the umask gives the usual mode
        yield tmp
        os.replace(tmp, target)
        done = True
    except OSError as exc:
        raise _write_error(target, exc) from None
    finally:
        if tmp.exists():
            tmp.unlink()
        if not done and made is not None:  # a failed write leaves no empty folder it made (a report on a full disk)
            remove_empty(target.parent, made)


def missing_top(folder: Path) -> Path | None:
    """The outermost folder on the way to `folder` (itself included) that does not exist yet, or None."""
    top = None
    for p in (folder, *folder.parents):
        if p.exists():
            break
        top = p
    return top


def remove_empty(folder: Path, top: Path) -> None:
    """Remove `folder` and its parents up to `top` while they are empty folders."""
    for p in (folder, *folder.parents):
        with contextlib.suppress(OSError):  # not empty (another writer), or gone: leave it
            p.rmdir()
        if p == top:
            break


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


SCHEMA_VERSION = "1.0"
"""The layout of the JSON files sloshid writes, stated in each as `schema_version`: the major number changes when a
reader of the old layout would misread the new one. A file without it was written before versions were stated (1.x)."""


def versioned(doc: dict[str, Any]) -> dict[str, Any]:
    """`doc` with `schema_version` first (an object that already states one keeps it)."""
    return {"schema_version": SCHEMA_VERSION, **doc}


def check_schema(doc: Any, path: str | os.PathLike) -> None:
    """Refuse, in one sentence, a file written by a newer sloshid in a layout this one cannot read (a newer major
    version); a file without a version is an older one's and is read."""
    version = doc.get("schema_version") if isinstance(doc, dict) else None
    if version is None:
        return
    major, ours = str(version).split(".")[0], int(SCHEMA_VERSION.split(".")[0])
    if not major.isdigit() or int(major) > ours:
        raise UserError(
            f"{path} was written by a newer sloshid (schema_version {version}, this one reads {ours}.x); update sloshid "
            "to read it."
        )


def write_json(path: str | os.PathLike, doc: Any) -> None:
    """Write a JSON document atomically, an object with its `schema_version`; non-finite numbers are refused (JSON has
    none), nothing is written then."""
    if isinstance(doc, dict):
        doc = versioned(doc)
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
    tmp = temporary_sibling(target, ".part")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp.mkdir()  # mode 0o777 less the umask: readable like any folder the user makes
        yield tmp
        os.replace(tmp, target)
    except OSError as exc:
        raise _write_error(target, exc) from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
