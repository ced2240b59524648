"""Identification verdicts that are earned: per-parameter verdicts, cross-checks that do not cry wolf on clean
decays, long quiet tails, and the first-mode choice with and without the container geometry."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sloshid.core.errors import UserError
from sloshid.core.spectrum import welch_spectrum
from sloshid.identification.decay_window import rough_mode_frequency
from sloshid.identification.estimator import Identifier
from sloshid.identification.signals import Signal, make_signal
from sloshid.model.pendulum import XI_CYLINDER_SECOND, cylinder_first_mode_omega
from sloshid.synthetic.decays import free_decay, free_decay_signal, tracker_noise

R_M, H_M = 0.049, 0.078  # the shared measured setup: first mode 3.047 Hz, second azimuthal mode 3.94 Hz


def test_noise_free_decay_is_good_in_every_group():
    # no noise at all: the Hilbert envelope once read its round-off tail and said 2.2-2.9 Hz against 3.44 Hz
    sig = free_decay_signal(3.44, 0.07, 30, duration_s=20, amplitude=8, noise_std=0.0, lead_in_s=0.5, seed=0)
    res = Identifier().fit(sig).result
    assert res.quality == "good", res.reasons
    assert {g: v.quality for g, v in res.groups.items()} == {"frequency": "good", "damping": "good"}
    # weighted by envelope^2 the Hilbert check now reads the ring-down, not its tail; where the strong damping
    # leaves it few effective periods it says so (and then does not sway the verdict)
    hilbert = res.cross_checks[0][2]
    assert abs(hilbert.f_hz / 3.44 - 1) < 0.02 or hilbert.n_periods < 8, hilbert


@pytest.mark.parametrize("seed", range(8))
def test_long_quiet_tail_with_tracker_hold_levels_is_identified(seed):
    # a 40 s tap test: 4 s of ring-down, then 35 s where the tracker holds its last value in steps of a few
    # thousandths of a degree (what `sloshid track` gives on a clean rendered video). Those steps beat the
    # near-zero noise floor, and the rough frequency fell on the search band's 0.5 Hz edge.
    t, y = free_decay(3.44, 0.07, 30, duration_s=39.5, lead_in_s=0.5, amplitude=8, noise_std=0.0, seed=seed)
    levels = np.repeat(np.random.default_rng(seed).normal(0, 0.004, 41), 30)[: t.size]
    sig = make_signal(t, np.where(np.abs(y) > 0.05, y, 0.0) + levels, "angle_deg", "deg", f"tap {seed}")
    assert rough_mode_frequency(sig, (0.5, 30.0)) == pytest.approx(3.44, rel=0.03)  # periodogram bins of 4 s
    res = Identifier().fit(sig).result
    assert res.groups["frequency"].quality == "good", res.reasons
    assert res.parameters["f_hz"].value == pytest.approx(3.44, rel=0.003)
    assert 0.45 <= res.windows[0].t0_s <= 0.8  # starts at the tap (0.5 s), not in the rest before it


def _higher_mode_dominates(seed: int = 3):
    """The tilted-run situation: the second azimuthal mode (3.94 Hz) rings stronger than the first (3.03 Hz)."""
    t, y = free_decay(3.94, 0.004, 60, duration_s=12, amplitude=6, noise_std=0.2, seed=seed)
    y = y + 4.5 * np.exp(-0.006 * 2 * np.pi * 3.03 * t) * np.cos(2 * np.pi * 3.03 * t + 0.7)
    return make_signal(t, y, "height_mm", "mm", "tilted")


def test_higher_mode_is_never_good_without_geometry():
    res = Identifier().fit(_higher_mode_dominates()).result
    assert res.parameters["f_hz"].value == pytest.approx(3.94, rel=0.01)  # the strongest peak wins the fit
    assert res.groups["frequency"].quality != "good"
    assert any("lies below the reported" in r for r in res.groups["frequency"].reasons), res.reasons


def test_geometry_picks_the_first_mode():
    f1 = cylinder_first_mode_omega(R_M, H_M) / (2 * np.pi)
    f2 = cylinder_first_mode_omega(R_M, H_M, XI_CYLINDER_SECOND) / (2 * np.pi)
    assert f1 == pytest.approx(3.047, abs=0.002) and f2 == pytest.approx(3.94, abs=0.01)  # the data README
    res = Identifier(container_radius_m=R_M, fill_height_m=H_M).fit(_higher_mode_dominates()).result
    assert res.parameters["f_hz"].value == pytest.approx(3.03, rel=0.005)  # 0.2 mm noise on a 4.5 mm mode
    lo, hi = res.prior["band_hz"]
    assert lo < 3.03 < hi < 3.94
    assert res.groups["frequency"].quality == "good", res.reasons


def test_per_parameter_verdicts_in_json_summary_and_report(tmp_path):
    from sloshid.identification.report import build_report

    res = Identifier(mass_kg=0.5).fit(_higher_mode_dominates()).result
    js = res.to_dict()
    for name in ("f_hz", "omega_rad_s", "l_m"):
        assert js["parameters"][name]["quality"] == res.groups["frequency"].quality
        assert js["parameters"][name]["reasons"] == list(res.groups["frequency"].reasons)
    for name in ("zeta", "d_ns_per_m"):
        assert js["parameters"][name]["quality"] == res.groups["damping"].quality
    assert "quality" not in js["parameters"]["m_kg"]  # given, not identified
    assert js["quality"] == res.quality and json.loads(json.dumps(js)) == js
    text = res.summary()
    assert "frequency (f, omega, l): uncertain" in text and "lies below the reported" in text
    page = build_report(res).save(tmp_path).read_text()
    verdict_block = page[page.index("Verdict:") : page.index("Source and sampling")]
    assert "lies below the reported" in verdict_block and 'class="meta"' not in verdict_block


def test_pipeline_index_opens_with_an_overall_verdict():
    from sloshid.workflow.index import overall_verdict
    from sloshid.workflow.pipeline import StageRecord

    ident = StageRecord(
        "identify", "k", "ran", 1.0, {"quality": "uncertain", "parameters": {"f_hz": {"quality": "good"}}}
    )
    plan = StageRecord("plan", "k", "ran", 1.0, {"limits_ok": True, "verification": {"ok": True}})
    rec = {"method": "sloshid_robust", "label": "sloshid robust plan", "risk": "good"}
    compare = StageRecord("compare", "k", "ran", 1.0, {"recommendation": rec})
    text, quality = overall_verdict([ident, plan, compare])
    assert quality == "good" and "liquid frequency good" in text and "recommended: sloshid robust plan" in text
    text, quality = overall_verdict([ident, StageRecord("plan", "k", "failed", 1.0, {}, "boom")])
    assert quality == "unreliable" and "plan failed" in text
    # a move the scenario's arm cannot follow is not sent: the verdict above "Do not send" must not be green
    arm = {"reason": "joint 5 acceleration 33 > 15 rad/s2"}
    plan_arm = StageRecord("plan", "k", "ran", 1.0, {"limits_ok": True, "verification": {"ok": True}, "arm": arm})
    compare_arm = StageRecord("compare", "k", "ran", 1.0, {"recommendation": rec, "recommended": {"arm": arm}})
    text, quality = overall_verdict([ident, plan_arm, compare_arm])
    assert quality == "uncertain" and text.count("robot arm cannot follow") == 2


def test_misfit_that_fades_with_the_mode_doubts_the_damping_only():
    # nonlinear crests: a second harmonic that decays twice as fast as the mode. The PT2 model cannot describe it,
    # so the residual is not white *and* shrinks with the oscillation: the damping (read off the envelope) is
    # doubted, the frequency is not. Stationary coloured noise alone (test_identify's AR(1) cases) stays good.
    from sloshid.synthetic.decays import tracker_noise

    t = np.arange(0, 10, 1 / 60)
    w, sigma = 2 * np.pi * 3.0, 0.02 * 2 * np.pi * 3.0
    y = 8 * np.exp(-sigma * t) * np.cos(w * t) + 2 * np.exp(-2 * sigma * t) * np.cos(2 * w * t + 0.5)
    y += tracker_noise(np.random.default_rng(0), t.size, 0.1, 0.3)
    res = Identifier().fit(make_signal(t, y, "height_mm", "mm", "crests")).result
    assert res.groups["frequency"].quality == "good", res.reasons
    assert res.groups["damping"].quality == "uncertain" and res.quality == "uncertain"
    assert any("fades with the oscillation" in r for r in res.groups["damping"].reasons)
    coloured = Identifier().fit(free_decay_signal(3.0, 0.02, 60, amplitude=8, rho=0.6, seed=2)).result
    assert coloured.quality == "good", coloured.reasons


def _red_record(seed: int, amplitude: float) -> Signal:
    """A 1-deg ring-down (3 Hz, zeta 0.01, 100 Hz, 15 s) in pure AR(1) noise of 0.23 deg correlated 0.9 per sample:
    noise whose density rises toward low frequencies, where the broadband median reads it three times too low."""
    t, y = free_decay(3.0, 0.01, 100, duration_s=15, amplitude=amplitude, noise_std=0.0, seed=seed, phase=0.0)
    y = y + tracker_noise(np.random.default_rng(100 + seed), t.size, 0.23, 0.9, share=1.0)
    return make_signal(t, y, "angle_deg", "deg", f"red {seed}")


def test_noise_levels_near_the_mode_and_in_the_period_mean():
    # white noise: both readings agree with the broadband one (within the scatter of a Welch median of a 15 s
    # record); AR(1) 0.9: the near-mode level finds the true 0.23 deg where the broadband median reads ~0.075
    t = np.arange(1500) / 100
    for seed in range(5):
        ring = np.exp(-0.19 * t) * np.cos(2 * np.pi * 3 * t)
        white = welch_spectrum(t, ring + tracker_noise(np.random.default_rng(seed), t.size, 0.23, 0.0), (0.5, 30))
        assert white.noise_near_mode() == pytest.approx(white.noise_std, rel=0.15)
        assert white.period_mean_noise(3.0) == pytest.approx(0.23 * np.sqrt(3 / 100), rel=0.35)  # 5 bins below f/2
        red = welch_spectrum(t, ring + tracker_noise(np.random.default_rng(seed), t.size, 0.23, 0.9, 1.0), (0.5, 30))
        assert red.noise_std < 0.1
        assert red.noise_near_mode() == pytest.approx(0.23, rel=0.15)
        assert red.period_mean_noise(3.0) > 2 * 0.23 * np.sqrt(3 / 100)


@pytest.mark.parametrize("seed", [9, 10, 19])
def test_clear_decay_in_correlated_noise_is_identified_and_doubted(seed):
    # the noise's slow wander passed for forcing against the broadband level until 13-15 s: seed 10 was refused
    # ("driven until 14.9 s"), seeds 9 and 19 were fitted in the noisy tail after it (f 6 % off, rated good)
    res = Identifier().fit(_red_record(seed, 1.0)).result
    assert res.windows[0].near_mode_noise == pytest.approx(0.23, rel=0.15)
    assert res.windows[0].t0_s < 1.0  # the ring-down from the start, not the record's noisy tail
    assert res.parameters["f_hz"].value == pytest.approx(3.0, rel=0.01)  # 0.9 % at most here; 1.2 % over 30 seeds
    for group in ("frequency", "damping"):
        assert res.groups[group].quality == "uncertain"
        assert any("correlated from sample to sample" in r for r in res.groups[group].reasons)


@pytest.mark.parametrize("seed", [0, 1, 3, 4])
def test_correlated_noise_alone_is_still_refused(seed):
    # the second search against the near-mode level makes no mode out of noise: these records stay refused
    with pytest.raises(UserError):
        Identifier().fit(_red_record(seed, 0.0))


@pytest.mark.parametrize("gap", [(4.0, 4.3), (2.0, 2.3), (3.0, 4.0)])
def test_a_gap_in_the_samples_does_not_move_the_window(gap):
    # lost frames (a float hidden for a while): the uniform grid's straight line across the gap moved the running
    # period mean, which passed for forcing, so the window started after the gap (4.63 instead of 0.90 s, f's interval
    # ten times wider); a gap of a second had no swing and ended the window as if the ring-down had faded
    t, y = free_decay(2.5, 0.03, 30, duration_s=7.5, amplitude=8, noise_std=0.1, lead_in_s=0.9, seed=4)
    whole = Identifier().fit(make_signal(t, y, "angle_deg", "deg", "whole")).result
    keep = (t < gap[0]) | (t >= gap[1])
    res = Identifier().fit(make_signal(t[keep], y[keep], "angle_deg", "deg", "gap")).result
    assert res.windows[0].t0_s == pytest.approx(whole.windows[0].t0_s, abs=0.05)
    assert res.windows[0].t1_s >= whole.windows[0].t1_s - 0.5  # not ended at the gap
    assert res.parameters["f_hz"].stderr < 1.5 * whole.parameters["f_hz"].stderr
    assert res.parameters["f_hz"].value == pytest.approx(2.5, rel=0.003)


@pytest.mark.parametrize("band", [(3.0, 10.0), (1.0, 2.2)])
def test_a_fit_outside_the_searched_band_is_unreliable(band):
    # --f-range 3,10 on a 2.5 Hz decay returned f = 2.498 Hz rated good: the band only seeds the fit
    sig = free_decay_signal(2.5, 0.03, 60, duration_s=8, amplitude=6, noise_std=0.1, seed=2)
    res = Identifier(f_range_hz=band).fit(sig).result
    assert res.parameters["f_hz"].value == pytest.approx(2.5, rel=0.01)
    assert res.groups["frequency"].quality == "unreliable"
    assert any("outside the searched band" in r for r in res.groups["frequency"].reasons)
    assert Identifier().fit(sig).result.groups["frequency"].quality == "good"


@pytest.mark.parametrize("seed", [1, 4, 5])
def test_a_liquid_at_rest_is_no_mode_not_a_driven_signal(seed):
    # a float on still liquid (a slow wander and tracker noise, no tap) was refused as "driven ... until 11 s", with
    # advice about containers moving in the picture; with no resonance anywhere the record holds no mode
    t = np.arange(360) / 30
    rng = np.random.default_rng(seed)
    y = 0.03 * np.sin(2 * np.pi * 0.25 * t + seed) + tracker_noise(rng, t.size, 0.01, 0.6)
    with pytest.raises(UserError, match="no oscillatory mode found"):
        Identifier().fit(make_signal(t, y, "angle_deg", "deg", f"still {seed}"))
