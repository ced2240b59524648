"""`sloshid compare` on the demo scenario reproduces the figures and verdict it gave before its simulations were
batched (issue 39): the same verdict, every angle within 0.01 deg."""

from __future__ import annotations

import contextlib
import io
import json

import pytest
from conftest import ROOT

# Reference: `sloshid compare data/scenarios/demo_move.toml --json` at commit 2e09c11 (before issue 39), when every
# simulation was scipy's adaptive DOP853 (rtol 1e-9) one pendulum at a time; rounded to 1e-6 deg.
# method -> (transfer_time_s, peak_during_deg, residual_deg)
METHODS = {
    "constant_acc": (2.079, 8.067318, 4.137174),
    "zv": (2.225, 2.955703, 0.002567),
    "zvd": (2.37, 2.936833, 0.007109),
    "ruckig": (2.39, 3.139806, 0.103163),
    "ruckig_tilt": (2.39, 0.556289, 0.103163),
    "sloshid": (2.132, 0.000577, 0.000684),
    "sloshid_robust": (2.171, 0.00035, 0.000352),
    "constant_acc_feedback": (4.823, 3.92555, 0.039733),
    "sloshid_feedback": (5.117, 0.32195, 0.136375),
}
# method -> (max_linear_nonlinear_gap_deg, peak_linear_deg, residual_linear_deg)
CLOSED = {
    "constant_acc": (0.018801, 8.012906, 4.236464),
    "zv": (0.003628, 3.146186, 0.035757),
    "zvd": (0.005339, 3.042345, 0.01319),
    "ruckig": (0.003763, 3.142703, 0.102018),
    "ruckig_tilt": (0.003763, 0.558771, 0.102005),
    "sloshid": (0.013815, 0.013781, 0.010337),
    "sloshid_robust": (0.00883, 0.008943, 0.001741),
    "constant_acc_feedback": (0.007897, 3.910023, 0.038519),
    "sloshid_feedback": (0.013588, 0.321134, 0.141246),
}
# label -> residual (deg) at frequency factors 0.9, 1.0, 1.1, then at damping factors 0.5, 1.0, 2.0
ROBUSTNESS = {
    "constant acceleration": ([2.646672, 4.137174, 2.057972], [5.683061, 4.137174, 3.175157]),
    "ZV shaped": ([0.330405, 0.002567, 0.279094], [0.296505, 0.002567, 0.282258]),
    "ZVD shaped": ([0.063997, 0.007109, 0.035704], [0.020229, 0.007109, 0.024876]),
    "jerk-limited (ruckig)": ([0.319954, 0.103163, 0.297329], [0.043296, 0.103163, 0.197058]),
    "jerk-limited (ruckig) + tilt": ([0.319954, 0.103163, 0.297329], [0.043296, 0.103163, 0.197058]),
    "sloshid plan": ([1.593824, 0.000684, 1.885072], [1.508726, 0.000684, 1.030753]),
    "sloshid robust plan": ([0.000223, 0.000352, 0.000765], [0.40906, 0.000352, 0.207642]),
    "constant acceleration + feedback": ([0.053574, 0.039733, 0.055996], [0.057421, 0.039733, 0.025446]),
    "sloshid plan + feedback": ([0.127216, 0.136375, 0.149528], [0.157743, 0.136375, 0.106459]),
}
# (base, camera_fps, transfer_time_s, peak_during_deg, residual_deg, seen_peak_deg)
CAMERA = [
    ("constant acceleration", 30.0, 4.821, 4.000172, 0.053574, 7.955222),
    ("constant acceleration", 60.0, 4.45, 3.911281, 0.085774, 8.037637),
    ("sloshid plan", 30.0, 5.117, 1.458532, 0.127216, 0.000564),
    ("sloshid plan", 60.0, 4.45, 1.330654, 0.086853, 0.000574),
]
NO_FEEDBACK = {"constant acceleration": 2.646672, "sloshid plan": 1.593824}
# (acc_m_s2, peak_linear_deg, peak_nonlinear_deg)
LINEARITY = [(0.5, 8.012906, 8.008638), (2.0, 29.28343, 28.6244)]
# recommendation band checks at the band's low end, nominal, high end: (peak_during_deg, residual_deg)
CHECKS = {
    "sloshid": ([1.141642, 0.000577, 1.457064], [1.005135, 0.000684, 1.21987]),
    "sloshid_robust": ([0.626837, 0.00035, 0.617916], [0.173785, 0.000352, 0.163486]),
}
VERDICT = (
    "Recommended: sloshid robust plan (2.17 s), the fastest move that stays slosh-free (residual <= 0.5 deg, peak "
    "during the move <= 1 deg) over 3.27-3.61 Hz, the nominal 3.44 Hz widened by 5 % (no identified interval); worst "
    "case there 0.17 deg residual, 0.63 deg peak. Faster ones lose: constant acceleration breaks a limit (move "
    "jerk_max 1e+03 > 100); sloshid plan leaves 1.2 deg of residual slosh at 3.61 Hz. The constant-acceleration "
    "profile sloshes to 8.07 deg during the move and leaves 4.14 deg behind. Frequency error tolerated with residual "
    "<= 0.5 deg: ZV shaped at -10 %, +0 %, +10 % (swept points; not simulated between them), ZVD shaped at -10 %, "
    "+0 %, +10 % (swept points; not simulated between them), sloshid plan +0 % .. +0 %, sloshid robust plan at "
    "-10 %, +0 %, +10 % (swept points; not simulated between them). The robust plan costs 1.8 % more transfer time. "
    "Robot limits fail for: jerk-limited (ruckig) + tilt. The scenario's [limits] fail for: constant acceleration, ZV "
    "shaped, ZVD shaped, constant acceleration + feedback, sloshid plan + feedback."
)

DEG = 0.01
"""Issue 39's bar: every angle within 0.01 deg of before."""
MS = 1.5e-3
"""Transfer times are counted in 1 ms samples (feedback: until the loop settles); one sample either way is allowed."""


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The JSON `sloshid compare data/scenarios/demo_move.toml --json` prints (run once for the module), with its
    [robot] fit_joints = false: the reference predates fitting the move to the arm, which slows the robust plan the
    demo recommends (tests/test_recommended_move.py); the comparison's own figures and judgement are these."""
    from sloshid.cli.app import main

    text = (ROOT / "data" / "scenarios" / "demo_move.toml").read_text()
    scenario = tmp_path_factory.mktemp("reference") / "demo_move.toml"
    scenario.write_text(text.replace('model = "panda"', 'model = "panda"\nfit_joints = false'))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["compare", str(scenario), "--json"]) == 0
    return json.loads(out.getvalue())


def test_demo_compare_scores_as_before(demo):
    rows = {m["method"]: m for m in demo["methods"]}
    assert set(rows) == set(METHODS)
    for key, (t, peak, resid) in METHODS.items():
        assert rows[key]["transfer_time_s"] == pytest.approx(t, abs=MS), key
        assert rows[key]["peak_during_deg"] == pytest.approx(peak, abs=DEG), key
        assert rows[key]["residual_deg"] == pytest.approx(resid, abs=DEG), key
    for key, (gap, peak, resid) in CLOSED.items():
        got = demo["closed_loop"][key]
        assert got["max_linear_nonlinear_gap_deg"] == pytest.approx(gap, abs=DEG), key
        assert got["peak_linear_deg"] == pytest.approx(peak, abs=DEG), key
        assert got["residual_linear_deg"] == pytest.approx(resid, abs=DEG), key


def test_demo_compare_studies_as_before(demo):
    rob = demo["robustness"]
    assert rob["omega_factors"] == [0.9, 1.0, 1.1] and rob["zeta_factors"] == [0.5, 1.0, 2.0]
    for label, (by_omega, by_zeta) in ROBUSTNESS.items():
        assert rob["residual_vs_omega_deg"][label] == pytest.approx(by_omega, abs=DEG), label
        assert rob["residual_vs_zeta_deg"][label] == pytest.approx(by_zeta, abs=DEG), label
    got = [(c["base"], c["camera_fps"]) for c in demo["camera"]]
    assert got == [(c[0], c[1]) for c in CAMERA]
    for c, ref in zip(demo["camera"], CAMERA):
        assert c["transfer_time_s"] == pytest.approx(ref[2], abs=MS)
        assert [c["peak_during_deg"], c["residual_deg"], c["seen_peak_deg"]] == pytest.approx(ref[3:], abs=DEG)
    assert demo["no_feedback_residual_at_camera_error_deg"] == pytest.approx(NO_FEEDBACK, abs=DEG)
    for p, ref in zip(demo["linearity"], LINEARITY, strict=True):
        assert (p["acc_m_s2"], p["peak_linear_deg"], p["peak_nonlinear_deg"]) == pytest.approx(ref, abs=DEG)


def test_demo_compare_recommends_and_judges_as_before(demo):
    rec = demo["recommendation"]
    assert (rec["method"], rec["risk"]) == ("sloshid_robust", "uncertain")
    assert set(rec["checks"]) == set(CHECKS)
    for key, (peak, resid) in CHECKS.items():
        assert rec["checks"][key]["peak_during_deg"] == pytest.approx(peak, abs=DEG), key
        assert rec["checks"][key]["residual_deg"] == pytest.approx(resid, abs=DEG), key
    assert demo["verdict"] == VERDICT
