"""Shared fixtures: paths to bundled and third-party data, a CLI runner that captures exit code and stderr, and a
stderr that is or is not a terminal (tqdm draws only on one)."""

from __future__ import annotations

import io
import os
from pathlib import Path

# The suite runs on two workers on two cores: OpenBLAS's own threads in each (one per core, busy-waiting) made a
# BLAS-heavy test four times slower (the ten measured runs' joint fit: 69 s against 17 s). Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]


def adaptive_liquid(traj, params, settle_s: float):
    """Liquid (phi, theta) in rad on the trajectory's grid extended by `settle_s`, by scipy's DOP853 at rtol 1e-12 on
    `pendulum_rhs_3d`: the input linear between samples and zero after arrival. A reference independent of sloshid's
    own simulator (`simulate_liquids`)."""
    import math

    import numpy as np
    from scipy.integrate import solve_ivp

    from sloshid.model.pendulum import pendulum_rhs_3d

    t, acc = traj.t_s, traj.acc_m_s2

    def rhs(tt, y, moving):
        u = [np.interp(tt, t, acc[:, k]) for k in range(3)] if moving else [0.0, 0.0, 0.0]
        d = pendulum_rhs_3d(np.r_[0, 0, 0, y[0], y[1], 0, 0, 0, 0, y[2], y[3], 0], u, params)
        return [d[3], d[4], d[9], d[10]]

    # max_step 1 ms: the input's kinks sit on the samples, so no step may straddle two of them
    move = solve_ivp(rhs, (t[0], t[-1]), np.zeros(4), "DOP853", t, rtol=1e-12, atol=1e-14, max_step=1e-3, args=(True,))
    after = t[-1] + traj.dt_s * np.arange(0, math.ceil(settle_s / traj.dt_s) + 1)
    rest = solve_ivp(rhs, (after[0], after[-1]), move.y[:, -1], "DOP853", after, rtol=1e-12, atol=1e-14, args=(False,))
    return np.vstack([move.y.T, rest.y.T[1:]])[:, :2]


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
