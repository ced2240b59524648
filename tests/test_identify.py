"""Identification on synthetic decays with known truth: recovery, windows, joint fit, interval calibration, API."""

from __future__ import annotations

import json
import math
import pickle
from dataclasses import replace

import control
import numpy as np
import pytest

from sloshid.core.errors import UserError
from sloshid.identification.estimator import Identifier, IdentSettings, NotFittedError
from sloshid.identification.pt2fit import (
    CODEC_ZETA_SHARE,
    FLOAT_CODEC_ZETA_SHARE,
    WindowData,
    encoder_hold,
    fit_pt2,
    hold_weight,
    zero_columns,
)
from sloshid.identification.signals import load_signal, make_signal
from sloshid.model.pendulum import TABLE_I, SloshParams, linear_tf
from sloshid.synthetic.decays import free_decay, free_decay_signal, tracker_noise

F_T1, Z_T1 = TABLE_I.f_hz, TABLE_I.zeta  # seed Table I: 3.44 Hz, zeta 0.070


def write_tracker_csv(path, t, angle, valid, key_frame=None):
    """A CSV in the tracker's column contract (only angle_deg/t_s/valid and key_frame matter to identify); without
    key_frame it is a file from before the tracker wrote that column."""
    head = "frame,t_s,angle_deg,float_angle_deg,container_angle_deg,x_px,y_px,quality,valid,angle_smoothed_deg"
    rows = [head + (",key_frame" if key_frame is not None else "")]
    for k, (ti, a, v) in enumerate(zip(t, angle, valid)):
        shown = a if v else 37.0  # invalid frames carry garbage that must be ignored
        row = f"{k},{ti:.6f},{shown:.5f},{shown:.5f},0.0,320.0,240.0,{0.9 if v else 0.1},{int(v)},{a:.5f}"
        rows.append(row + (f",{int(key_frame[k])}" if key_frame is not None else ""))
    path.write_text("\n".join(rows) + "\n")


def test_recovers_table_i_from_noisy_decay():
    # 10 s at 60 fps, 0.3 deg tracker-like noise: the benchmark's 95th percentile errors are ~0.3 % (f) and ~6 %
    # (zeta) over random draws, so 0.3 % / 8 % here, plus the truth inside 3 reported standard errors.
    sig = free_decay_signal(F_T1, Z_T1, 60, amplitude=10, rho=0.4, seed=11)
    res = Identifier(mass_kg=0.5).fit(sig).result
    f, z, d = res.parameters["f_hz"], res.parameters["zeta"], res.parameters["d_ns_per_m"]
    assert f.value == pytest.approx(F_T1, rel=0.003) and abs(f.value - F_T1) < 3 * f.stderr
    assert z.value == pytest.approx(Z_T1, rel=0.08) and abs(z.value - Z_T1) < 3 * z.stderr
    assert res.parameters["l_m"].value == pytest.approx(0.021, rel=0.006)  # l ~ 1/f^2: twice f's tolerance
    assert d.value == pytest.approx(1.51, rel=0.09)
    assert d.ci95[0] < 1.51 < d.ci95[1] or abs(d.value - 1.51) < 3 * d.stderr
    assert res.quality == "good", res.reasons
    assert res.fit_percent(0) > 80  # A = 10 deg against 0.3 deg noise


def test_uneven_timestamps_gaps_and_invalid_frames_through_cli(tmp_path, run_cli):
    # variable frame rate (+-30 % jitter), 10 % frames lost by the tracker (valid = 0, garbage angle)
    t, y = free_decay(2.8, 0.04, 50, amplitude=8, jitter=0.3, seed=5, rho=0.3)
    valid = np.random.default_rng(1).uniform(size=t.size) > 0.1
    csv = tmp_path / "track.csv"
    write_tracker_csv(csv, t, y, valid)
    out = tmp_path / "p.json"
    code, stdout, err = run_cli("identify", csv, "-o", out)
    assert code == 0, err
    data = json.loads(out.read_text())
    per = data["fit"]["per_signal"][0]
    assert per["sampling"]["n_dropped"] == int((~valid).sum())
    assert per["sampling"]["timestamp_jitter_s"] > 0.002  # jitter of 0.3 frames at 50 fps is visible
    assert "interpolated" in data["psd"]["per_signal"][0]["resampling"]  # Welch needed a uniform grid; the fit did not
    assert data["parameters"]["f_hz"]["value"] == pytest.approx(2.8, rel=0.004)
    assert data["parameters"]["zeta"]["value"] == pytest.approx(0.04, rel=0.12)
    assert "verdict: good" in stdout and "skipped" in err


def test_window_skips_quiet_lead_in_and_forced_motion(tmp_path):
    # 4 s rest, 3 s of slow forced swing (0.4 Hz, large offset), then the free decay of the mode
    fps, f0, z0 = 60, 3.0, 0.03
    t = np.arange(0, 20, 1 / fps)
    rng = np.random.default_rng(3)
    y = np.where((t > 4) & (t < 7), 15 * np.sin(np.pi * (t - 4) / 3) ** 2, 0.0)
    td = t - 7
    y += np.where(td > 0, 6 * np.exp(-z0 * 2 * np.pi * f0 * td) * np.sin(2 * np.pi * f0 * np.sqrt(1 - z0**2) * td), 0)
    y += tracker_noise(rng, t.size, 0.2, 0.3)
    res = Identifier().fit(make_signal(t, y, "height_mm", "mm", "forced")).result
    w = res.windows[0]
    assert 6.5 < w.excitation_end_s < 7.5  # the forcing ends at 7 s
    assert 7.0 <= w.t0_s < 8.0  # the ring-down starts at 7 s; a sample earlier would bias zeta
    assert res.parameters["f_hz"].value == pytest.approx(f0, rel=0.003)
    assert res.parameters["zeta"].value == pytest.approx(z0, rel=0.1)
    # the end is found from the signal alone, and said to be an estimate (a move's slow end can outlast it)
    legend = [text.get_text() for text in res.plot_signal(0).get_legend().get_texts()]
    assert "estimated end of forcing" in legend
    page = res.report(tmp_path).read_text()
    assert f"after the estimated end of forcing, dashed, at {w.excitation_end_s:.2f} s" in page


def test_a_given_window_over_the_forcing_is_judged_uncertain():
    # --window 0.2,5.9 over a tracked robot move and its ring-down gave f 1.2 % low and zeta a quarter of the truth,
    # rated good: the spline zero took the move in. Here the seed's linear model (3 Hz, zeta 0.05) under a 1 s
    # bang-bang move of 2 m/s^2 from 0.5 s, sampled at 30 fps: the reason must be named, whatever else is doubted
    p = SloshParams.from_modal(2 * math.pi * 3.0, 0.05, 0.5)
    fine = np.arange(0, 6, 1 / 3000)
    accel = np.where((fine >= 0.5) & (fine < 1.0), 2.0, 0.0) - np.where((fine >= 1.0) & (fine < 1.5), 2.0, 0.0)
    y = np.degrees(control.forced_response(linear_tf(p), fine, accel).outputs)[::100]
    t = fine[::100]
    sig = make_signal(t, y + tracker_noise(np.random.default_rng(5), t.size, 0.05, 0.3), "angle_deg", "deg", "move")
    res = Identifier(window_s=(0.2, 5.9)).fit(sig).result
    assert 1.2 < res.windows[0].excitation_end_s < 1.6  # the move ends at 1.5 s
    for group in ("frequency", "damping"):
        assert res.groups[group].quality != "good"
        assert any("before the forced motion in it ends" in r for r in res.groups[group].reasons)
    auto = Identifier().fit(sig).result  # the automatic window starts after the move: 3 Hz, zeta 0.05, no doubt
    assert auto.parameters["f_hz"].value == pytest.approx(3.0, rel=0.002) and auto.quality == "good"
    # a second move later in the record is no forcing of a window that ends before it (review: a window 0.2 s after
    # the first move of two was told the forcing lasted until the second's end)
    twice = np.concatenate([y, y[1:]])
    sig2 = make_signal(np.arange(twice.size) / 30, twice, "angle_deg", "deg", "two moves")
    res2 = Identifier(window_s=(1.7, 5.9)).fit(sig2).result
    assert res2.windows[0].excitation_end_s is None
    assert not any("forced motion" in r for g in res2.groups.values() for r in g.reasons)


def test_joint_fit_shares_frequency_and_damping():
    # three tap tests of the same liquid: different amplitude, phase, offset, rate
    sigs = [
        free_decay_signal(3.2, 0.05, fps, amplitude=a, seed=s, rho=0.3)
        for fps, a, s in ((30, 6, 1), (60, 9, 2), (120, 4, 3))
    ]
    joint = Identifier().fit(sigs).result
    singles = [Identifier().fit(s).result for s in sigs]
    f = joint.parameters["f_hz"]
    assert f.value == pytest.approx(3.2, rel=0.002)
    assert joint.parameters["zeta"].value == pytest.approx(0.05, rel=0.06)
    # pooling three records must tighten the frequency interval compared with each record alone
    assert f.stderr < min(s.parameters["f_hz"].stderr for s in singles)
    sigma = joint.fit.zeta * joint.fit.omega_rad_s  # amplitudes are at each window start: back to t = 0
    at_zero = [joint.fit.amplitude(i) * math.exp(sigma * joint.windows[i].t0_s) for i in range(3)]
    assert at_zero == pytest.approx([6, 9, 4], rel=0.05)  # 0.3 deg noise on 4-9 deg amplitudes
    assert len(joint.to_dict()["window_s"]) == 3


def test_interval_coverage_on_seeded_batch():
    # 40 seeded trials (10 s, 30-120 fps, 0.3 deg noise with AR(1) correlation up to 0.6). For a true 95 % interval
    # the hit count is Binomial(40, 0.95): P(<= 34) = 2.4 %, so >= 35 hits is the lower bound; too wide intervals
    # are caught by the spread check: reported stderr must match the actual error spread within a factor 1.5.
    rng = np.random.default_rng(2024)
    hits = {"f_hz": 0, "zeta": 0}
    z_scores = {"f_hz": [], "zeta": []}
    for k in range(40):
        f0, z0 = rng.uniform(2.5, 4.5), rng.uniform(0.02, 0.08)
        sig = free_decay_signal(
            f0, z0, rng.uniform(30, 120), amplitude=rng.uniform(5, 15), rho=rng.uniform(0, 0.6), seed=1000 + k
        )
        res = Identifier().fit(sig).result
        for key, truth in (("f_hz", f0), ("zeta", z0)):
            est = res.parameters[key]
            hits[key] += est.ci95[0] <= truth <= est.ci95[1]
            z_scores[key].append((est.value - truth) / est.stderr)
    for key in hits:
        assert hits[key] >= 35, (key, hits[key])
        spread = np.std(z_scores[key])
        assert 1 / 1.5 < spread < 1.5, (key, spread)


def test_pure_noise_and_constant_are_refused():
    from sloshid.core.errors import UserError

    t = np.arange(0, 10, 1 / 60)
    noise = make_signal(t, np.random.default_rng(0).normal(size=t.size), "x", "", "noise")
    with pytest.raises(UserError, match="no oscillatory mode"):
        Identifier().fit(noise)
    with pytest.raises(UserError, match="constant"):
        Identifier().fit(make_signal(t, np.full(t.size, 2.0), "x", "", "flat"))


def _two_modes(f2, z2, a2, seed=4):
    """A 3.0 Hz, zeta 0.02, 6 deg ring-down (0.3 deg noise, 60 fps, 10 s) plus a second mode (f2, z2, a2 at t = 0)."""
    t, y = free_decay(3.0, 0.02, 60, amplitude=6, seed=seed)
    y = y + a2 * np.exp(-z2 * 2 * np.pi * f2 * t) * np.cos(2 * np.pi * f2 * t + 1.0)
    return make_signal(t, y, "a_deg", "deg", "two modes")


def test_two_mode_fit_recovers_the_first_mode_beside_a_strong_second(tmp_path):
    # a 4.1 Hz mode at 2/3 of the 3.0 Hz one's amplitude, the situation of the tilted real runs (3.0 + 3.97 Hz)
    from sloshid.identification.report import build_report

    res = Identifier().fit(_two_modes(4.1, 0.015, 4.0)).result
    sm = res.second_mode
    assert sm is not None and sm.separated, sm and sm.problems
    assert res.fit is sm.fit and res.fit.second is not None
    f, z = res.parameters["f_hz"], res.parameters["zeta"]
    # 0.3 deg noise on 6 deg: f sd ~0.001 Hz, zeta sd ~0.0003; tolerances are ~3 sd, and the truth within 3 sd
    assert f.value == pytest.approx(3.0, rel=0.001) and abs(f.value - 3.0) < 3 * f.stderr
    assert z.value == pytest.approx(0.02, rel=0.06) and abs(z.value - 0.02) < 3 * z.stderr
    assert res.fit.second.omega_rad_s / (2 * math.pi) == pytest.approx(4.1, rel=0.002)
    assert res.fit.second.zeta == pytest.approx(0.015, rel=0.15)
    assert sm.amplitude_share(0) == pytest.approx(4 / (4 + 6), abs=0.03)
    # the single-mode model, blind to the second mode, is pulled off the true frequency by more than the two-mode one
    assert abs(sm.single.omega_rad_s / (2 * math.pi) - 3.0) > 2 * abs(f.value - 3.0)
    assert res.quality == "good", res.reasons
    js = res.to_dict()
    assert js["second_mode"]["separated"] and js["second_mode"]["f_hz"]["value"] == pytest.approx(4.1, rel=0.002)
    assert "a2 exp(-zeta2" in js["fit"]["model"] and "second mode: f2 = 4.1" in res.summary()
    page = build_report(res).save(tmp_path).read_text()  # the HTML report shows the second mode and the rule's outcome
    assert "Second mode" in page and "Here they are separated." in page


def test_single_mode_signal_uses_the_single_mode_model():
    res = Identifier().fit(free_decay_signal(3.0, 0.03, 60, amplitude=8, rho=0.3, seed=6)).result
    assert res.second_mode is None and res.fit.second is None
    js = res.to_dict()
    assert js["second_mode"] is None and "zeta2" not in js["fit"]["model"]


def test_second_component_that_is_no_free_decay_stays_uncertain():
    # a 4 Hz component whose amplitude grows (energy fed from the main mode, as in a short window of a tilted run):
    # the two-mode model cannot describe it, so the strong second peak keeps the verdict uncertain
    t, y = free_decay(3.0, 0.01, 60, amplitude=6, seed=4)
    y = y + (0.5 + 0.3 * t) * np.cos(2 * np.pi * 4.0 * t)
    res = Identifier().fit(make_signal(t, y, "a_deg", "deg", "growing second")).result
    assert res.second_mode is not None and not res.second_mode.separated
    assert res.fit is res.second_mode.single  # the main mode's numbers come from the single-mode fit
    assert res.quality == "uncertain"
    assert any("second mode" in r and "could not separate" in r for r in res.reasons), res.reasons


@pytest.mark.parametrize("f2", [3.15, 3.3])
def test_close_modes_are_not_separated(f2):
    # modes 0.15-0.3 Hz apart in a 10 s window are under 2 Welch bins (0.2 Hz) apart: least squares can trade one
    # for the other, so the rule refuses the two-mode fit (the PSD merges them into one broad peak anyway)
    from sloshid.core.spectrum import welch_spectrum
    from sloshid.identification.pt2fit import WindowData, fit_pt2, fit_two_modes
    from sloshid.identification.second_mode import separation_problems

    sig = _two_modes(f2, 0.02, 5.0)
    win = [WindowData(sig.t_s, sig.value, 0.0)]
    single = fit_pt2(win, [2 * math.pi * 3.0])
    two = fit_two_modes(win, single, 2 * math.pi * f2)
    problems = separation_problems(two, single, welch_spectrum(sig.t_s, sig.value).resolution_hz, 3.0)
    assert any("resolution bins apart" in p for p in problems), problems


def test_estimator_api_unfitted_pickle_and_planner_contract(tmp_path):
    ident = Identifier(IdentSettings(mass_kg=0.5))
    with pytest.raises(NotFittedError, match="not fitted"):
        _ = ident.result
    ident.fit(free_decay_signal(F_T1, Z_T1, 90, seed=8))
    back = pickle.loads(pickle.dumps(ident))
    assert back.result_.parameters["f_hz"].value == ident.result_.parameters["f_hz"].value
    assert isinstance(ident.params_, SloshParams)
    path = tmp_path / "p.json"
    path.write_text(json.dumps(ident.result_.to_dict()))
    read = SloshParams.from_identify_json(path)  # the planner's reader
    assert read.l_m == pytest.approx(ident.params_.l_m, rel=1e-12)
    assert read.d_ns_per_m == pytest.approx(ident.params_.d_ns_per_m, rel=1e-12)
    tf = ident.result_.tf  # seed eq. 5: DC gain 1/g rad per m/s^2
    assert float(np.real(tf.dcgain())) == pytest.approx(1 / 9.81, rel=1e-9)
    assert math.isclose(ident.result_.to_dict()["transfer_function"]["num"][0], 1 / 9.81)


def test_seed_pendulum_ring_down_after_a_move_gives_table_i():
    # The nonlinear seed eq. 2 with Table I, driven by a +-1 m/s^2 bang-bang move (peak ~15 deg), then left to
    # ring down; the end-to-end target is l within 1 % and d within 10 %.
    from scipy.integrate import solve_ivp

    from sloshid.model.pendulum import angle_accel

    def accel(t):
        return 1.0 if 1.0 < t < 1.4 else (-1.0 if 1.4 < t < 1.8 else 0.0)

    t = np.arange(0, 10, 1 / 60)

    def seed_eq2(t, y):  # written out here, independent of the package's integrator
        return [y[1], angle_accel(y[0], y[1], accel(t), TABLE_I)]

    sol = solve_ivp(seed_eq2, (0, 10), [0, 0], t_eval=t, max_step=0.002, rtol=1e-9)
    y = np.degrees(sol.y[0]) + tracker_noise(np.random.default_rng(0), t.size, 0.3, 0.3)
    res = Identifier(mass_kg=0.5).fit(make_signal(t, y, "angle_deg", "deg", "seed eq. 2")).result
    assert res.windows[0].t0_s > 1.8  # the move ends at 1.8 s
    assert res.parameters["l_m"].value == pytest.approx(0.021, rel=0.01)
    assert res.parameters["d_ns_per_m"].value == pytest.approx(1.51, rel=0.10)
    assert res.quality == "good", res.reasons


def test_settings_from_toml_table_and_paths(tmp_path):
    # the pipeline configures identify from a TOML table: typos are caught with a suggestion, tuples coerced
    from sloshid.core.errors import UserError
    from sloshid.core.settings import from_dict

    st = from_dict(IdentSettings, {"mass_kg": 0.5, "f_range_hz": [1, 10]}, "[identify]")
    assert st.f_range_hz == (1.0, 10.0)
    with pytest.raises(UserError, match="did you mean 'mass_kg'"):
        from_dict(IdentSettings, {"mass_kgs": 0.5}, "[identify]")
    t, y = free_decay(3.0, 0.03, 60, seed=9)
    path = tmp_path / "s.csv"
    path.write_text("t_s,angle_deg\n" + "\n".join(f"{a},{b}" for a, b in zip(t, y)))
    res = Identifier(st).fit(path).result  # a path is read with load_signal's defaults
    assert res.parameters["f_hz"].value == pytest.approx(3.0, rel=0.003)


def test_drift_option_recovers_a_creeping_zero():
    # a float creeping across the surface: the zero drifts by 0.4 deg/s under the ring-down
    t, y = free_decay(3.0, 0.02, 60, amplitude=6, seed=12)
    sig = make_signal(t, y + 0.4 * t, "angle_deg", "deg", "drifting")
    res = Identifier(drift=True).fit(sig).result
    assert res.fit.linear[0][3] == pytest.approx(0.4, abs=0.03)  # 0.3 deg noise over 10 s: slope sd ~0.005 deg/s
    assert res.parameters["f_hz"].value == pytest.approx(3.0, rel=0.002)
    assert res.parameters["zeta"].value == pytest.approx(0.02, rel=0.1)
    assert res.to_dict()["fit"]["per_signal"][0]["drift_per_s"] == pytest.approx(0.4, abs=0.03)
    # with a window of the user's too: the straight line is the drift, not a moving zero for a spline
    res = Identifier(drift=True, window_s=(0.0, 8.0)).fit(sig).result
    assert res.fit.slow_s is None and res.fit.linear[0][3] == pytest.approx(0.4, abs=0.03)


def _tap_with_sway(sway_deg: float, sway_hz: float, seed: int):
    """A 3 Hz, zeta 0.03 tap test (tapped at 1 s, 12 s at 60 fps, 0.1 deg correlated noise) under a slow sinusoidal
    sway of its zero (a container swaying in the picture), and the same record without the sway."""
    t, y = free_decay(3.0, 0.03, 60, duration_s=11, amplitude=5, noise_std=0.1, rho=0.3, seed=seed, lead_in_s=1.0)
    sway = sway_deg * np.sin(2 * np.pi * sway_hz * t + seed)
    return make_signal(t, y + sway, "angle_deg", "deg", "swaying"), make_signal(t, y, "angle_deg", "deg", "still")


@pytest.mark.parametrize("sway_deg,sway_hz,seed", [(0.6, 0.2, 1), (1.5, 0.4, 2), (3.0, 0.3, 3)])
def test_a_slow_sway_of_the_zero_is_fitted_beside_the_mode(sway_deg, sway_hz, seed):
    # a sway of 12-60 % of the tap's swing once counted as forcing until the end ("no free ring-down") or gave
    # intervals 4-20 times wider; fitted as a spline zero, the result is that of the same record without it
    swaying, still = _tap_with_sway(sway_deg, sway_hz, seed)
    res, ref = Identifier().fit(swaying).result, Identifier().fit(still).result
    assert ref.fit.slow_s is None  # a still zero keeps the constant
    assert res.fit.slow_s == pytest.approx(2 / 3.0, rel=0.01)  # knots two mode periods apart
    assert 1.0 <= res.windows[0].t0_s < 1.35  # from the tap's first crests, not from before it
    f, z = res.parameters["f_hz"], res.parameters["zeta"]
    # truth within 3 reported standard errors, and the intervals no more than 1.5 times the still record's
    assert abs(f.value - 3.0) < 3 * f.stderr and abs(z.value - 0.03) < 3 * z.stderr
    assert f.stderr < 1.5 * ref.parameters["f_hz"].stderr and z.stderr < 1.5 * ref.parameters["zeta"].stderr
    assert "zero: moves slowly" in res.summary() and any("sway" in n for n in res.notes)
    assert res.to_dict()["fit"]["slow_zero"]["knot_spacing_s"] == pytest.approx(res.fit.slow_s)


def test_a_noise_free_trace_with_a_sway_is_identified():
    # a simulation's (or the renderer's truth) trace has no noise level to fade to: the ring-down's quiet tail is
    # where it stays under 1 % of its largest swing; the twiced running mean's edge effect must not count as ringing
    # (30 s: a long quiet tail drives the noise estimate toward zero, as in a rendered clip's truth)
    t, y = free_decay(3.0, 0.03, 60, duration_s=30, amplitude=5, noise_std=0.0, seed=4, lead_in_s=1.0)
    res = Identifier().fit(make_signal(t, y + 2 * np.sin(2 * np.pi * 0.4 * t), "angle_deg", "deg", "exact")).result
    assert res.fit.slow_s is not None
    # the spline follows the 0.4 Hz sway to a few thousandths of a degree: f to 0.01 %, zeta to 0.3 %
    assert res.parameters["f_hz"].value == pytest.approx(3.0, rel=1e-4)
    assert res.parameters["zeta"].value == pytest.approx(0.03, rel=3e-3)


def test_the_spline_zero_holds_constants_and_reports_its_start():
    # the JSON's "offset" is the spline's first coefficient: the zero at the window's start (clamped knots), and the
    # splines sum to one, so a constant zero is still one coefficient repeated
    t = np.linspace(0, 4.3, 300)
    cols = zero_columns(t, False, 0.6)
    assert cols.shape == (300, 8 + 3)  # ceil(4.3 / 0.6) = 8 knot intervals, cubic
    assert np.allclose(cols.sum(axis=1), 1.0)
    coef = np.linalg.lstsq(cols, 0.5 + 0.2 * np.sin(0.9 * t), rcond=None)[0]
    assert coef[0] == pytest.approx(0.5, abs=1e-3)  # a 0.9 rad/s sway: knots every 0.6 s follow it to 1e-3


def test_a_fit_with_no_more_samples_than_parameters_is_refused():
    # 6 samples for 2 + 2 + 4 parameters (mode, amplitude and phase, the fewest spline coefficients: one interval)
    # would fit exactly and report a standard error of 0
    t = np.arange(6) / 30.0
    window = WindowData(t, np.cos(2 * np.pi * 3.0 * t), 0.0)
    with pytest.raises(UserError, match="6 samples for 8 parameters"):
        fit_pt2([window], [2 * np.pi * 3.0], slow_s=0.05)


def test_a_sway_in_a_window_the_user_gave_is_fitted_too():
    # the user's window skips the automatic search; the constant-zero fit's residual still shows the sway
    swaying, _ = _tap_with_sway(1.5, 0.4, 2)
    res = Identifier(window_s=(1.0, 6.0)).fit(swaying).result
    assert res.fit.slow_s is not None
    assert abs(res.parameters["f_hz"].value - 3.0) < 3 * res.parameters["f_hz"].stderr
    # the fit plot shows the zero the mode rides on; it follows the sway to within the noise (0.1 deg)
    zero = next(line for line in res.plot_fit(0).get_lines() if line.get_label() == "fitted slow zero")
    t = zero.get_xdata()
    assert np.sqrt(np.mean((zero.get_ydata() - 1.5 * np.sin(2 * np.pi * 0.4 * t + 2)) ** 2)) < 0.1


@pytest.mark.parametrize("f0,z0", [(2.5, 0.02), (3.0, 0.05)])
def test_cross_checks_agree_with_truth(f0, z0):
    # the three independent methods are coarser than the fit: frequency within 1.5 %, zeta within 30 %
    # (peaks lifted by noise bias the decrement low, the periodogram's finite window widens the half-power band)
    res = Identifier().fit(free_decay_signal(f0, z0, 60, amplitude=10, rho=0.3, seed=1)).result
    methods = {c.method: c for c in res.cross_checks[0]}
    assert set(methods) == {"half-power bandwidth", "logarithmic decrement", "Hilbert envelope"}
    for c in methods.values():
        assert c.f_hz == pytest.approx(f0, rel=0.015), c
        assert c.zeta == pytest.approx(z0, rel=0.3), c


def test_tracked_signals_fit_the_encoder_hold(tmp_path):
    # a 0.05 deg hold (what H.264/MPEG-4 leave on a tracked float's angle, README) on an exact 2.5 Hz decay pulls a
    # plain fit's f low and zeta high; a signal from `sloshid track` is fitted through a hold whose width is fitted
    # with it: width, f and zeta come back (measured: w 0.0509 +- 0.0014, f +0.004 %, zeta -0.11 %; tolerances are
    # three to four standard errors of this seeded draw), and the intervals cover the truth
    t, y = free_decay(2.5, 0.04, 60, duration_s=5, amplitude=6, noise_std=0.0, seed=0, lead_in_s=0.5)
    held = encoder_hold(y, 0.05) + np.random.default_rng(0).normal(0, 0.01, y.size)
    csv = tmp_path / "track.csv"
    write_tracker_csv(csv, t, held, np.ones(t.size, bool))
    tracked = load_signal(csv)
    assert tracked.tracked == "float"  # the tracker's columns mark it
    plain, fl, surface = (Identifier().fit(replace(tracked, tracked=k)).result for k in ("", "float", "surface"))
    f0, f1 = (r.parameters["f_hz"] for r in (plain, fl))
    z0, z1 = (r.parameters["zeta"] for r in (plain, fl))
    assert f0.value < 2.5 * (1 - 0.0008) and z0.value > 0.04 * 1.008  # the bias exists without the hold
    assert plain.fit.hold is None and plain.to_dict()["fit"]["encoder_hold"] is None
    hold = fl.fit.hold
    assert hold.width == pytest.approx(0.05, abs=0.005) and hold.width_se < 0.005
    assert hold.weight > 0.9999  # a width ten errors from zero: the held fit's values
    assert f1.value == pytest.approx(2.5, rel=2e-4) and z1.value == pytest.approx(0.04, rel=0.01)
    assert f1.ci95[0] <= 2.5 <= f1.ci95[1] and z1.ci95[0] <= 0.04 <= z1.ci95[1]
    # zeta's error holds the shift from the plain fit and a float's 2.5 % of zeta for the swings a codec shrinks
    # (plain rendered floats at CRF 16-20: the interval had covered the truth in 5 of 12 without any share)
    assert z1.stderr**2 >= hold.shift[1] ** 2 + (FLOAT_CODEC_ZETA_SHARE * z1.value) ** 2
    assert surface.parameters["f_hz"].value == f1.value  # one model for both targets
    doc = fl.to_dict()["fit"]["encoder_hold"]
    assert doc["half_width"] == hold.width and doc["unit"] == "deg"
    assert doc["shift_from_plain_fit"]["omega_rad_s"] > 0  # the hold fit moved f up from the plain fit's
    assert "encoder hold (fitted" in fl.summary() and "encoder's hold" in " ".join(fl.notes)


def test_tracked_zeta_interval_allows_for_the_codec_shrink(tmp_path):
    # H.264's P-frames take about the same angle off every swing of a tracked float, with little lag (rendered floats
    # at CRF 23: 0.1-0.3 deg): the Table I decay (3.44 Hz, zeta 0.07, 8 deg) with 0.15 deg taken off each swing. The
    # hold, which cannot shrink a swing without delaying it, leaves zeta 5-9 % high (measured on five seeds) and
    # its interval missed the truth; a refit with the shrink finds it (measured 0.135-0.168 deg) and the distance
    # between the two fits, with how far zeta moves for a shrink one residual rms larger, widens zeta's interval
    # until it covers the truth. The values stay the held fit's: f within 0.1 % (measured +0.045 %)
    t, y = free_decay(3.44, 0.07, 60, duration_s=5, amplitude=8, noise_std=0.0, seed=0, lead_in_s=0.5)
    swing = np.where(t >= 0.5, 8 * np.exp(-0.07 * 2 * np.pi * 3.44 * (t - 0.5)), 0.0)
    shrunk = y * np.clip(1 - 0.15 / np.maximum(swing, 1e-12), 0, None)
    csv = tmp_path / "track.csv"
    write_tracker_csv(csv, t, shrunk + np.random.default_rng(0).normal(0, 0.02, t.size), np.ones(t.size, bool))
    result = Identifier().fit(csv).result
    z, hold = result.parameters["zeta"], result.fit.hold
    assert z.value > 0.07 * 1.03  # the bias the interval is widened for
    assert z.ci95[0] <= 0.07 <= z.ci95[1]
    assert hold.shrink == pytest.approx(0.15, abs=0.03)
    assert hold.shrink_shift < -0.03 * 0.07 and hold.shrink_hidden < 0  # a shrink reads as a faster decay
    assert z.stderr >= math.hypot(hold.shrink_shift, hold.shrink_hidden)
    assert result.parameters["f_hz"].value == pytest.approx(3.44, rel=1e-3)
    doc = result.to_dict()["fit"]["encoder_hold"]
    assert doc["shrink"] == hold.shrink and doc["zeta_shift_from_shrink"] == hold.shrink_shift
    assert doc["zeta_hidden_shrink"] == hold.shrink_hidden
    assert "codec shrink" in result.summary()


def test_the_encoder_hold_restarts_at_key_frames(tmp_path):
    # MPEG-4 as sloshid synth writes it codes every 12th picture afresh, so the hold that the P-frames between build
    # up is gone there (on a rendered 60 fps float: angle error RMS 0.05 deg on key frames, 0.13 deg between them).
    # An exact 2 Hz decay at 120 fps through a 0.15 deg hold that restarts every 12 frames: fitted through a hold
    # that never restarts (a CSV without key_frame), f comes out low (measured -0.19 %); with the key_frame column
    # the hold restarts where the video's did and f, zeta and the width come back (measured f -0.008 %, zeta -0.1 %,
    # w 0.150; tolerances about three times that, well inside the reported errors), one key frame not valid too
    t, y = free_decay(2.0, 0.03, 120, duration_s=5, amplitude=2, noise_std=0.0, seed=0, lead_in_s=0.5)
    keys = np.arange(t.size) % 12 == 0
    held = np.concatenate([encoder_hold(part, 0.15) for part in np.split(y, np.flatnonzero(keys)[1:])])
    held += np.random.default_rng(1).normal(0, 0.01, y.size)
    valid = np.ones(t.size, bool)
    valid[np.flatnonzero(keys)[20]] = False  # the restart still happened: the next valid sample starts afresh
    old, new = tmp_path / "old.csv", tmp_path / "new.csv"
    write_tracker_csv(old, t, held, valid)
    write_tracker_csv(new, t, held, valid, keys)
    assert load_signal(old).key_t_s is None
    assert load_signal(new).key_t_s == pytest.approx(t[keys], abs=1e-6)
    never, restarting = (Identifier().fit(p).result for p in (old, new))
    assert never.parameters["f_hz"].value < 2.0 * (1 - 0.001)  # the bias a hold without restarts leaves
    f, z = restarting.parameters["f_hz"], restarting.parameters["zeta"]
    assert f.value == pytest.approx(2.0, rel=3e-4) and z.value == pytest.approx(0.03, rel=0.01)
    assert restarting.fit.hold.width == pytest.approx(0.15, abs=0.005)
    # every key frame after the window's first sample restarts it once (the invalid one at the next valid sample)
    win = restarting.windows[0]
    inside = t[valid & (t >= win.t0_s) & (t <= win.t1_s)]
    key_t = t[keys]
    assert restarting.fit.hold.restarts == np.sum((key_t > inside[0]) & (key_t <= inside[-1])) > 30
    assert never.fit.hold.restarts == 0
    assert restarting.to_dict()["fit"]["encoder_hold"]["restarts_at_key_frames"] == restarting.fit.hold.restarts
    assert f"restarting at {restarting.fit.hold.restarts} key frames" in restarting.summary()
    assert f.ci95[0] <= 2.0 <= f.ci95[1] and z.ci95[0] <= 0.03 <= z.ci95[1]


def test_tracked_signal_without_a_hold_is_left_alone():
    # a clean tracked decay (tracker-like noise, no hold): the fitted width is zero within its error (measured 1e-10)
    # and f and zeta move by far less than their standard errors (0.1 of them) from the plain fit; the intervals
    # widen (f 1.6x), since the width is a free parameter
    sig = free_decay_signal(2.5, 0.04, 60, amplitude=6, rho=0.3, seed=3)
    plain, tracked = (Identifier().fit(replace(sig, tracked=k)).result for k in ("", "float"))
    hold = tracked.fit.hold
    assert hold.width < 2 * hold.width_se + 1e-3
    for key in ("f_hz", "zeta"):
        a, b = plain.parameters[key], tracked.parameters[key]
        assert abs(a.value - b.value) < 0.1 * a.stderr, key
    assert "hold" not in tracked.fit.at_bound and tracked.quality == plain.quality


def test_a_hold_that_noise_could_have_made_is_taken_by_its_evidence():
    # tracking noise alone fits a small hold, which moves f up (decay0 of the pbr corpus: a 0.068 +- 0.068 deg hold
    # took f from +0.48 % to +0.93 %): the values are the plain and held fits averaged by the hold's Akaike weight,
    # 1 / (1 + exp(1 - z^2 / 2)) with z its width over its standard error (even at z^2 = 2, the price of one more
    # parameter), and the interval is widened to hold the held fit's. A seeded decay0-like draw (3.44 Hz, 30 fps,
    # 0.15 deg of white noise, no hold): width 0.51 of its error, weight 0.295; f plain +0.07 %, held +0.17 %
    assert hold_weight(0.0, 1.0) == pytest.approx(1 / (1 + math.e))
    assert hold_weight(math.sqrt(2), 1.0) == pytest.approx(0.5)
    assert hold_weight(5.0, 1.0) > 0.9999 and hold_weight(0.0, 0.0) == 0.0
    t, y = free_decay(3.44, 0.07, 30, duration_s=3.6, amplitude=5, noise_std=0.15, seed=10, lead_in_s=0.4)
    sig = make_signal(t, y, "angle_deg", "deg", "noise")
    plain, tracked = (Identifier().fit(replace(sig, tracked=k)).result for k in ("", "surface"))
    hold = tracked.fit.hold
    assert 0 < hold.width < hold.width_se and 1 / (1 + math.e) < hold.weight < 0.5  # weak evidence: mostly plain
    f0, f1 = plain.parameters["f_hz"], tracked.parameters["f_hz"]
    held = f0.value + hold.shift[0] / (2 * math.pi)
    assert held > f0.value * (1 + 0.0005)  # the noise's hold moved f up
    assert f1.value == pytest.approx(f0.value + hold.weight * (held - f0.value), rel=1e-12)
    assert f1.ci95[0] < min(f0.value, 3.44) and f1.ci95[1] > max(held, 3.44)  # covers both fits and the truth
    assert tracked.to_dict()["fit"]["encoder_hold"]["weight"] == hold.weight


def test_estimates_show_digits_down_to_their_error():
    # f = 1.9996 +- 0.0002 Hz read "2" and its interval "1.999 .. 2" in the report's 4-digit table
    from sloshid.identification.estimates import estimate

    f = estimate(1.9996, 0.0002)
    assert f.shown() == "1.9996" and f.shown(f.ci95[0]) == "1.99921"  # 1.9996 - 1.96 * 0.0002, to 0.00001
    assert estimate(3.44, 0.5).shown() == "3.44"  # at least 5 significant digits, trailing zeros dropped
    assert estimate(0.070123456, 0.0000123).shown() == "0.070123"  # down to 0.000001, the error's 2nd digit


def test_the_report_table_keeps_the_digits_the_error_allows(tmp_path):
    sig = free_decay_signal(2.0, 0.03, 120, amplitude=8, seed=11, duration_s=20)
    res = Identifier().fit(sig).result
    f = res.parameters["f_hz"]
    assert f.stderr < 0.001  # a long clean decay: the table must show the 4th decimal
    html = res.report(tmp_path / "rep").read_text()
    assert f"<td>{f.shown()}</td>" in html and len(f.shown()) >= 6


def test_the_report_plots_draw_the_resonance_peak_and_leave_gaps_empty():
    # the Bode plot's 400 points over three decades drew a zeta-0.004 peak at a fifth of its height (a trial read 5
    # against 8.95), and the fit was drawn straight across a lost stretch
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, y = free_decay(3.0, 0.004, 60, amplitude=8, noise_std=0.05, seed=5)
    keep = (t < 4.0) | (t > 4.6)  # a lost stretch of 0.6 s
    res = Identifier().fit(make_signal(t[keep], y[keep], "angle_deg", "deg", "gap")).result
    axes = res.plot_bode()
    drawn = max(line.get_ydata().max() for line in axes[0].get_lines() if len(line.get_ydata()) > 2)
    w = res.fit.omega_rad_s * (1 + np.linspace(-0.05, 0.05, 20001))
    peak = np.abs(control.frequency_response(res.tf, w).magnitude).max()
    assert drawn == pytest.approx(peak, rel=0.005)
    ax = res.plot_fit()
    fit_line = next(line for line in ax.get_lines() if "fit" in line.get_label())
    tx, fy = np.asarray(fit_line.get_xdata(), float), np.asarray(fit_line.get_ydata(), float)
    inside = (tx > 4.05) & (tx < 4.55)
    assert not inside.any() and np.isnan(fy).sum() == 1  # one break, at the gap
    plt.close("all")


def test_a_tracked_float_zeta_interval_allows_for_the_codec_losing_its_small_swings():
    # what H.264 CRF 20 did to the painted float of benchmarks/track_pbr.py (30 fps, 3.44 Hz, zeta 0.07, 5 deg): the
    # tracked swing's gain falls from 1.00 above 2.2 deg to 0.87 below 1 deg (measured 0.86-0.87; 1.00 losslessly),
    # here on an exact decay with 0.04 deg of noise (seeded). zeta reads 6 % high (the bias stays in the value; seeds
    # 0-5: +6 to +11 %); the interval with 1 % of zeta for the codec, which a surface keeps, ends above the truth
    # (measured 0.0702), with a float's 2.5 % it holds it (0.0690; seeds 0-5: 5 of 6 covered, 2 of 6 at 1 %)
    t, y = free_decay(3.44, 0.07, 30, duration_s=3.6, amplitude=5, noise_std=0.0, seed=2, lead_in_s=0.4)
    swing = 5 * np.exp(-0.07 * 2 * math.pi * 3.44 * np.clip(t - 0.4, 0, None))
    shrunk = (0.87 + 0.13 * np.clip((swing - 1.0) / 1.2, 0, 1)) * y + np.random.default_rng(2).normal(0, 0.04, y.size)
    sig = make_signal(t, shrunk, "angle_deg", "deg", "codec")
    fl, surface = (Identifier().fit(replace(sig, tracked=k)).result.parameters["zeta"] for k in ("float", "surface"))
    assert fl.value == surface.value > 0.07 * 1.05  # the same fit; only the allowance differs
    assert fl.ci95[0] <= 0.07 <= fl.ci95[1] and surface.ci95[0] > 0.07
    assert fl.stderr**2 == pytest.approx(
        surface.stderr**2 + (FLOAT_CODEC_ZETA_SHARE**2 - CODEC_ZETA_SHARE**2) * fl.value**2, rel=1e-9
    )


def test_a_clipped_record_is_not_given_a_good_damping():
    # a 3 Hz decay clipped at +-2 (a saturated sensor): 76 samples on the limits, zeta 31 % low with its interval
    # excluding the truth and only "the model misfits the mode" said (a trial)
    t, y = free_decay(3.0, 0.02, 60, duration_s=12, amplitude=5, noise_std=0.02, seed=3, lead_in_s=1.0)
    res = Identifier().fit(make_signal(t, np.clip(y, -2, 2), "angle_deg", "deg", "clipped")).result
    damping = res.groups["damping"]
    assert damping.quality == "unreliable" and any("stop flat at 2 deg" in r for r in damping.reasons)
    clean = Identifier().fit(make_signal(t, y, "angle_deg", "deg", "clean")).result
    assert not any("stop flat" in r for g in clean.groups.values() for r in g.reasons)


def test_the_codec_share_of_zeta_does_not_hide_runs_that_disagree(tmp_path):
    # the 1 % of zeta for the codec entered each run's own fit too, where the agreement test read it as independent
    # errors: two tracked runs at zeta 0.030 and 0.0306 were called agreeing, and the joint interval narrowed (a
    # review). It is added to the joint fit only, after the runs' agreement is judged
    runs = []
    for k, zeta in enumerate((0.030, 0.0306)):
        t, y = free_decay(2.0, zeta, 60, duration_s=6, amplitude=6, noise_std=0.0, seed=k, lead_in_s=0.5)
        held = encoder_hold(y, 0.03) + np.random.default_rng(k).normal(0, 0.005, y.size)
        csv = tmp_path / f"run{k}.csv"
        write_tracker_csv(csv, t, held, np.ones(t.size, bool))
        runs.append(load_signal(csv))
    res = Identifier().fit(runs).result
    assert res.between is not None and res.between.zeta.disagree
    z = res.parameters["zeta"]
    assert z.ci95[0] <= 0.030 and z.ci95[1] >= 0.0306  # both runs' damping inside the joint interval
    assert z.stderr >= FLOAT_CODEC_ZETA_SHARE * z.value  # tracked floats


def test_a_quantised_record_is_not_called_clipped_unless_it_is():
    # whole millimetres from a logger: a lightly damped peak holds its top value for some 10 samples at two peaks,
    # which was called clipped and rated unreliable (a review); clipped at 12 of 20 mm it still is
    t, y = free_decay(1.0, 0.002, 100, duration_s=20, amplitude=20, noise_std=0.1, seed=4, lead_in_s=1.0)
    quantised = Identifier().fit(make_signal(t, np.round(y), "wall_height_mm", "mm", "logger")).result
    assert not any("stop flat" in r for g in quantised.groups.values() for r in g.reasons)
    cut = Identifier().fit(make_signal(t, np.round(np.clip(y, -12, 12)), "wall_height_mm", "mm", "cut")).result
    assert any("stop flat at 12 mm" in r for r in cut.groups["damping"].reasons)


@pytest.mark.parametrize("seed", [10, 11])
def test_slow_noise_in_the_period_mean_is_not_taken_for_forcing(seed):
    # a thin float's tracked angle wanders by tenths of a degree over seconds (a path-traced stick on juice: 0.3 deg):
    # its one-period mean left the white-noise level and passed for forcing until 6 s, so a clear 8 s ring-down was
    # refused ("driven", or no ring-down of 3 periods). Sought again against the period mean's measured noise, these
    # two of 36 seeded decays with AR(1) noise (rho 0.9) that were refused read f within 0.03 % and zeta within 1.1 %
    # (the other 34 are unchanged); the tolerances are the noise's, 0.3 deg on a 4 deg swing
    sig = free_decay_signal(2.8, 0.015, 30.0, duration_s=8.0, amplitude=4.0, noise_std=0.3, rho=0.9, seed=seed)
    p = Identifier().fit(sig).result.parameters
    assert p["f_hz"].value == pytest.approx(2.8, rel=0.002)
    assert p["zeta"].value == pytest.approx(0.015, rel=0.05)
