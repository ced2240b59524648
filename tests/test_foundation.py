"""The shared pieces: model sign convention, settings validation, atomic writes, CLI error handling."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from sloshid.core.atomic import atomic_path
from sloshid.core.errors import UserError
from sloshid.core.settings import from_dict
from sloshid.model.conventions import steady_tilt
from sloshid.model.pendulum import TABLE_I, SloshParams, cylinder_first_mode_omega, pendulum_rhs_3d


def test_table_i_modal_values():
    # Seed Table I quoted in design.md: f = 3.44 Hz, zeta = 0.070 (rounded as printed).
    assert TABLE_I.f_hz == pytest.approx(3.44, abs=0.005)
    assert TABLE_I.zeta == pytest.approx(0.070, abs=0.0005)
    back = SloshParams.from_modal(TABLE_I.omega_rad_s, TABLE_I.zeta, 0.5)
    assert back.l_m == pytest.approx(0.021, rel=1e-12)
    assert back.d_ns_per_m == pytest.approx(1.51, rel=1e-12)


def test_cylinder_prior_matches_antisloshing_readme():
    # The data README quotes 3.047 Hz for R = 49 mm, h = 78 mm.
    assert cylinder_first_mode_omega(0.049, 0.078) / (2 * math.pi) == pytest.approx(3.047, abs=0.001)


@pytest.mark.parametrize("u", [(0.8, 0.0, 0.0), (0.0, 0.8, 0.0), (-0.5, 1.2, 0.0), (0.6, -0.4, 1.5)])
def test_constant_acceleration_settles_at_steady_tilt(u):
    # design.md convention: theta -> atan(ux/(g+uz)), phi -> -atan(uy/(g+uz)); strong damping to settle fast.
    params = SloshParams.from_modal(2 * math.pi * 3.0, 0.5)
    sol = solve_ivp(lambda t, o: pendulum_rhs_3d(o, u, params), (0, 6), np.zeros(12), rtol=1e-10, atol=1e-12)
    phi, theta = sol.y[3, -1], sol.y[4, -1]
    phi_ss, theta_ss = steady_tilt(*u)
    assert theta == pytest.approx(theta_ss, abs=1e-6)
    assert phi == pytest.approx(phi_ss, abs=1e-6)
    assert math.copysign(1, theta_ss) == math.copysign(1, u[0]) or u[0] == 0
    assert sol.y[6, -1] == pytest.approx(u[0] * 6, rel=1e-9)  # the free point mass integrates ux
    assert sol.y[5, -1] == 0.0  # psi' = 0


@dataclass
class _Limits:
    acc_max: tuple[float, float, float]
    tilt_max_deg: float = 30.0


def test_settings_reject_unknown_key_with_suggestion():
    with pytest.raises(UserError, match=r"unknown key '\[limits\]\.tilt_max_dg'.*did you mean 'tilt_max_deg'"):
        from_dict(_Limits, {"acc_max": [1, 1, 1], "tilt_max_dg": 3}, "[limits]")
    with pytest.raises(UserError, match="must have 3 entries"):
        from_dict(_Limits, {"acc_max": [1, 1]}, "[limits]")
    with pytest.raises(UserError, match="missing required key"):
        from_dict(_Limits, {}, "[limits]")
    ok = from_dict(_Limits, {"acc_max": [1, 2, 3]}, "[limits]")
    assert ok.acc_max == (1.0, 2.0, 3.0) and ok.tilt_max_deg == 30.0


def test_atomic_path_keeps_old_file_on_failure(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("good")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "good"
    assert list(tmp_path.iterdir()) == [target]


def test_cli_without_command_shows_help(run_cli):
    code, out, _ = run_cli()
    assert code == 2 and "track" in out and "identify" in out
