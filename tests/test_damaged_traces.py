"""Identification stays honest on damaged traces (issue 39): with 5-30 % of the frames lost, at random or in bursts,
a 'good' verdict's 95 % interval holds the truth as often as it claims, and every doubt says what to do."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

import sloshid
from sloshid.core.errors import UserError
from sloshid.identification.signals import make_signal
from sloshid.synthetic.decays import free_decay, free_decay_signal

F_HZ, ZETA = 3.44, 0.05
SEEDS = 40


def damaged(seed: int, lost: float, how: str):
    """A 60 fps, 10 s decay of 10 deg in 0.3 deg white noise, with a share `lost` of its frames removed at random or
    in bursts of 5-40 frames (a float that leaves its colour range for up to two thirds of a second)."""
    t, y = free_decay(F_HZ, ZETA, 60, duration_s=10, amplitude=10, noise_std=0.3, seed=seed, lead_in_s=1.0)
    rng = np.random.default_rng(1000 + seed)
    keep = rng.uniform(size=t.size) >= lost
    if how == "bursts":
        keep[:] = True
        while (~keep).mean() < lost:
            n = int(rng.integers(5, 40))
            start = int(rng.integers(0, t.size - n))
            keep[start : start + n] = False
    # as the tracker CSV's reader counts the frames it skips
    return replace(make_signal(t[keep], y[keep], "angle_deg", "deg", f"seed {seed}"), n_dropped=int((~keep).sum()))


@pytest.mark.slow
def test_good_intervals_hold_the_truth_on_traces_with_lost_frames():
    missed = {"f_hz": [0, 0], "zeta": [0, 0]}  # [good verdicts, intervals that miss the truth]
    refused = 0
    conditions = [(how, lost) for how in ("random", "bursts") for lost in (0.05, 0.15, 0.3)]
    for c, (how, lost) in enumerate(conditions):
        for seed in range(c * SEEDS, (c + 1) * SEEDS):  # other traces in every condition: independent misses
            try:
                params = sloshid.identify(damaged(seed, lost, how)).to_dict()["parameters"]
            except UserError:  # 30 % in bursts can leave no clean decay: a refusal claims nothing
                refused += 1
                continue
            for key, truth in (("f_hz", F_HZ), ("zeta", ZETA)):
                if params[key]["quality"] == "good":
                    lo, hi = params[key]["ci95"]
                    missed[key][0] += 1
                    missed[key][1] += not lo <= truth <= hi
    assert refused <= 0.1 * 6 * SEEDS  # most damaged traces are still identified
    for key, (good, misses) in missed.items():
        # a 95 % interval misses 5 % of the time; more misses than a 1 %-level binomial test allows would be a claim
        # it does not keep. White noise: with tracker-like correlated noise (AR(1), rho 0.6) the intervals miss
        # 11-12 % already on undamaged traces, lost frames or not (issue 39's report: open)
        assert good > 0.8 * 6 * SEEDS and stats.binom.sf(misses - 1, good, 0.05) > 0.01, (key, good, misses)


def test_lost_frames_are_said_in_the_verdict_notes():
    res = sloshid.identify(damaged(0, 0.15, "bursts"))
    notes = " ".join(res.to_dict()["notes"])
    assert "were lost or invalid and are left out" in notes


def test_every_doubt_says_what_to_do():
    # a short decay judged against strict settings: too few periods and a fit below the bar, both 'uncertain'
    res = sloshid.identify(
        free_decay_signal(F_HZ, ZETA, 60, seed=0, duration_s=3, amplitude=10, noise_std=0.3),
        min_periods=15,
        min_fit_percent=99.9,
    )
    reasons = res.to_dict()["reasons"]
    assert res.to_dict()["quality"] == "uncertain" and len(reasons) == 2
    assert "record a longer decay" in reasons[0] or "record a longer decay" in reasons[1]
    assert all("(`window_s`)" in r for r in reasons)  # and how to give the window that helps


def test_more_lost_than_the_checked_share_is_uncertain_and_says_what_to_do():
    # a yellow float tracked in a colour range it half left (60 fps, 3 Hz, zeta 0.05): 57 % of the frames lost, at
    # the angles where its hue left the range; identify fitted 1.95 Hz and called it 'good' with an interval that
    # missed 3 Hz. Beyond the 30 % the intervals were checked on, the verdict is at most uncertain, and says why
    res = sloshid.identify(damaged(0, 0.5, "random")).to_dict()
    assert res["parameters"]["f_hz"]["quality"] != "good" and res["parameters"]["zeta"]["quality"] != "good"
    assert any("past the 30 % on which the intervals were checked" in r for r in res["reasons"])
    assert any("track with another colour range" in r for r in res["reasons"])
