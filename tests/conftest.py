"""Shared fixtures: paths to bundled and third-party data, a CLI runner that captures exit code and stderr, and a
stderr that is or is not a terminal (tqdm draws only on one)."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
ANTISLOSHING = ROOT.parent / "shared" / "data" / "antisloshing"


@pytest.fixture
def run_cli(capsys):
    """Run `sloshid ARGS...` in-process; returns (exit_code, stdout, stderr)."""
    from sloshid.cli.app import main

    def _run(*args: str) -> tuple[int, str, str]:
        code = main([str(a) for a in args])
        out = capsys.readouterr()
        return code, out.out, out.err

    return _run


@pytest.fixture(scope="session")
def antisloshing_dir() -> Path:
    """The ten measured runs in ../shared/data/antisloshing (skip when the checkout has no shared/)."""
    if not ANTISLOSHING.is_dir():
        pytest.skip("../shared/data/antisloshing is not beside this checkout")
    return ANTISLOSHING


class _Terminal(io.StringIO):
    """A stderr that says it is a terminal, so that tqdm draws (it stays quiet on pipes and files)."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def stderr_as(monkeypatch):
    """stderr_as(terminal) puts a fresh text buffer in place of sys.stderr, a terminal or not, and returns it."""

    def _swap(terminal: bool) -> io.StringIO:
        err = _Terminal() if terminal else io.StringIO()
        monkeypatch.setattr("sys.stderr", err)
        return err

    return _swap
