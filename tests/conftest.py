"""Shared fixtures: paths to bundled and third-party data, and a CLI runner that captures exit code and stderr."""

from __future__ import annotations

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
    """The eight measured runs in ../shared/data/antisloshing (skip when the checkout has no shared/)."""
    if not ANTISLOSHING.is_dir():
        pytest.skip("../shared/data/antisloshing is not beside this checkout")
    return ANTISLOSHING
