"""Signals identified jointly that disagree: Cochran's Q, the random-effects interval, and what identify reports."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sloshid.identification.between import HETEROGENEITY_P, agreement
from sloshid.identification.estimator import Identifier
from sloshid.identification.pt2fit import Z95
from sloshid.synthetic.decays import free_decay_signal


def test_agreement_matches_the_closed_form():
    # two estimates 0 and 1 with standard errors 0.1: weighted mean 0.5, Q = 2 (0.5 / 0.1)^2 = 50 on 1 degree of
    # freedom; DerSimonian-Laird tau^2 = (Q - 1) / (sum w - sum w^2 / sum w) = 49 / (200 - 100) = 0.49; the
    # random-effects standard error of the mean sqrt((0.01 + 0.49) / 2) = 0.5
    a = agreement(np.array([0.0, 1.0]), np.array([0.1, 0.1]))
    assert a.q == pytest.approx(50.0)
    assert a.dof == 1
    assert a.tau == pytest.approx(0.7)
    assert a.stderr == pytest.approx(0.5)
    assert a.disagree and a.p < 1e-10
    # equal estimates: no spread, the fixed-effect error of the mean
    same = agreement(np.array([2.0, 2.0, 2.0]), np.array([0.1, 0.1, 0.1]))
    assert (same.q, same.tau, same.p) == (0.0, 0.0, 1.0)
    assert same.stderr == pytest.approx(0.1 / math.sqrt(3))
    assert not same.disagree
    # damping ratios that disagree: mean 0.0045, half-width 1.96 sqrt(tau^2 + se^2) past it; the JSON read -0.00079 for
    # the lower end of the shared real runs', a negative damping ratio, while the text showed 0
    low = agreement(np.array([0.002, 0.007]), np.array([0.0001, 0.0001]))
    assert low.prediction95[0] == 0.0 and low.prediction95[1] == pytest.approx(
        0.0045 + Z95 * math.hypot(low.tau, low.stderr)
    )


def test_runs_of_one_liquid_keep_the_joint_interval():
    # three seeded tap tests of one liquid (3.2 Hz, zeta 0.05): their single estimates scatter as their errors say
    sigs = [
        free_decay_signal(3.2, 0.05, fps, amplitude=a, seed=s, rho=0.3)
        for fps, a, s in ((30, 6, 1), (60, 9, 2), (120, 4, 3))
    ]
    res = Identifier().fit(sigs).result
    assert res.between is not None
    assert res.between.omega.p > HETEROGENEITY_P and res.between.zeta.p > HETEROGENEITY_P
    assert res.between.widened == (1.0, 1.0)
    assert not any("disagree" in n for n in res.notes)
    doc = res.to_dict()["fit"]["between_signals"]["f_hz"]
    # each run alone lands on the truth within 4 of its own standard errors (95 % intervals are 1.96)
    assert (np.abs(np.array(doc["per_signal"]) - 3.2) < 4 * np.array(doc["per_signal_stderr"])).all()


def test_runs_that_ring_differently_widen_the_interval_to_cover_them():
    # two liquids (3.0 and 3.09 Hz: 3 %) given as one: each run's own interval is about +-0.15 %, and the joint fit's
    # (its residual holds the misfit) covers neither; the random-effects interval of their mean must cover both
    sigs = [free_decay_signal(f, 0.04, 60, amplitude=8, seed=s, rho=0.2) for f, s in ((3.0, 5), (3.09, 6))]
    res = Identifier().fit(sigs).result
    f = res.parameters["f_hz"]
    assert res.between.omega.disagree
    assert res.between.widened[0] > 1.5
    assert f.ci95[0] < 3.0 and f.ci95[1] > 3.09
    assert res.parameters["l_m"].stderr == pytest.approx(2 * res.parameters["l_m"].value * f.stderr / f.value, rel=0.01)
    note = next(n for n in res.notes if "disagree" in n)
    assert "f from 2.998 Hz" in note and "to 3.09 Hz" in note and "widened" in note
    assert res.to_dict()["fit"]["between_signals"]["f_hz"]["disagree"] is True


def test_a_single_signal_has_no_between_test():
    res = Identifier().fit(free_decay_signal(3.2, 0.05, 60, amplitude=6, seed=4)).result
    assert res.between is None
    assert res.to_dict()["fit"]["between_signals"] is None


def test_the_summary_says_whether_the_signals_agree():
    sigs = [free_decay_signal(f, 0.04, 60, amplitude=8, seed=s, rho=0.2) for f, s in ((3.0, 5), (3.09, 6))]
    line = next(x for x in Identifier().fit(sigs).result.summary().splitlines() if "fitted alone" in x)
    assert "f 2.998-3.09 Hz" in line and "f disagree" in line and "widened" in line and "zeta agree" in line


def test_the_band_a_move_must_hold_over_is_where_one_more_run_may_land(tmp_path):
    # review: the widened interval was that of the mean (it excluded 4 of the 8 real runs) and centred on the joint
    # estimate, not the random-effects mean; compare's robustness band must cover where a run may ring
    from sloshid.model.pendulum import IdentifiedFrequency

    sigs = [free_decay_signal(f, 0.04, 60, amplitude=8, seed=s, rho=0.2) for f, s in ((3.0, 5), (3.09, 6))]
    res = Identifier().fit(sigs).result
    omega = res.between.omega
    lo, hi = res.frequency_band_hz
    assert lo < 3.0 and hi > 3.09 and (lo, hi) == pytest.approx([v / (2 * math.pi) for v in omega.prediction95])
    f = res.parameters["f_hz"]  # the liquid's f: its interval takes in the random-effects mean
    assert f.ci95[0] < omega.mean / (2 * math.pi) < f.ci95[1]
    path = tmp_path / "p.json"
    path.write_text(json.dumps(res.to_dict()))
    assert IdentifiedFrequency.from_identify_json(path).ci95_hz == pytest.approx((lo, hi))
    one = Identifier().fit(sigs[0]).result  # a single run: its own interval
    assert one.frequency_band_hz == one.parameters["f_hz"].ci95


def test_runs_of_two_liquids_are_told_apart_not_averaged():
    # a 3.0 Hz and a 4.5 Hz run identified together: fitted alone around the joint 3.0 Hz (+-25 %), the 4.5 Hz run got
    # an error of 0.74 Hz and the two "agreed" (p = 0.04); each window is now searched around its own PSD peak, and
    # both verdict groups say the runs differ (the joint zeta came out 0.050 where each run gives 0.031)
    sigs = [free_decay_signal(f, 0.03, 60, amplitude=8, seed=s, rho=0.2) for f, s in ((3.0, 7), (4.5, 8))]
    res = Identifier().fit(sigs).result
    per_run = np.array(res.between.omega.values) / (2 * math.pi)
    assert per_run == pytest.approx([3.0, 4.5], rel=0.003) and res.between.omega.disagree
    for group in ("frequency", "damping"):
        assert res.groups[group].quality != "good"
        assert any("identify them apart" in r.lower() for r in res.groups[group].reasons)


def test_runs_from_batch_folders_are_named_by_their_folder(tmp_path):
    # every batch output is videos/<name>-<hash>/angles.csv: the notes and reasons named all of them "angles.csv"
    from sloshid.identification.signals import make_signal

    paths = [tmp_path / "videos" / name / "angles.csv" for name in ("a1", "b1")]
    sigs = [free_decay_signal(f, 0.04, 60, amplitude=8, seed=s, rho=0.2) for f, s in ((3.0, 5), (3.09, 6))]
    sigs = [make_signal(sig.t_s, sig.value, "angle_deg", "deg", str(p)) for sig, p in zip(sigs, paths)]
    note = next(n for n in Identifier().fit(sigs).result.notes if "disagree" in n)
    assert "(a1/angles.csv)" in note and "(b1/angles.csv)" in note
