"""The ten measured antisloshing runs (known physics: first mode 3.047 Hz) and the HTML report's content."""

from __future__ import annotations

import json
import math
import re

import pytest

from sloshid.core.hashing import file_sha256
from sloshid.identification.estimator import Identifier
from sloshid.identification.signals import load_signal
from sloshid.identification.stage import identify_sources

F_PHYS = 3.047  # analytic first mode for R = 49 mm, h = 78 mm (data README); a force-torque log shows 3.05 Hz


def test_real_runs_frequency_and_verdicts(antisloshing_dir):
    runs = sorted((antisloshing_dir / "slosh").glob("*.mat"))
    assert len(runs) == 10
    results = {p.stem: identify_sources([p]) for p in runs}
    for name, res in results.items():
        f = res.parameters["f_hz"].value
        # every run, good or not, must land within the +-2 % the issue allows (nonlinear, 20-50 mm crests)
        assert abs(f / F_PHYS - 1) < 0.02, (name, f)
    good = [n for n, r in results.items() if r.groups["frequency"].quality == "good"]
    # measured: 8 of 10 good frequencies (the target is 85 % of the first eight, of which 7 are good): the wall
    # amplitude of TRD_2D grows until the recording stops, and the 3-D figure-eight LE_3D (shared for issue 38) reads
    # an uncertain frequency
    assert len(good) >= 8, {n: r.reasons for n, r in results.items()}
    grow = results["TRD_2D_0.3m_2.2s_270deg"]
    assert grow.groups["damping"].quality == "unreliable" and "zeta" in grow.fit.at_bound
    # the run with a 62.8 % fit whose log decrement (0.004) lies far outside the fit's zeta interval (0.0011-0.0021):
    # its frequency stands, its damping does not
    tilt_rd = results["Tilt_RD_2D_0.3m_7s_30deg"]
    assert tilt_rd.groups["frequency"].quality == "good" and tilt_rd.groups["damping"].quality == "uncertain"
    assert tilt_rd.quality == "uncertain"
    assert any("logarithmic decrement" in r for r in tilt_rd.groups["damping"].reasons)
    # the tilted run with the 3.97 Hz second mode (data README): fitted as a second mode, separated from the first
    tilt = results["Tilt_TRD_2D_0.3m_3s_30deg"]
    assert tilt.second_mode is not None and tilt.second_mode.separated, tilt.second_mode.problems
    assert tilt.fit.second.omega_rad_s / (2 * math.pi) == pytest.approx(3.97, abs=0.05)


def test_joint_identification_of_all_runs(antisloshing_dir):
    sigs = [load_signal(p) for p in sorted((antisloshing_dir / "slosh").glob("*.mat"))]
    res = Identifier().fit(sigs).result
    assert abs(res.parameters["f_hz"].value / F_PHYS - 1) < 0.02
    assert len(res.windows) == 10 and all(w.t0_s > 10 for w in res.windows)  # ~10 s quiet lead-in plus motion


def test_report_has_every_figure_and_table(antisloshing_dir, tmp_path, run_cli):
    src = antisloshing_dir / "slosh" / "Tilt_RD_2D_0.3m_7s_30deg.mat"
    out, rep = tmp_path / "p.json", tmp_path / "rep"
    code, stdout, err = run_cli(
        "identify",
        src,
        "-o",
        out,
        "--mass",
        "0.59",
        "--report",
        rep,
        "--container-radius-m",
        "0.049",
        "--fill-height-m",
        "0.078",
    )
    assert code == 0, err
    page = (rep / "index.html").read_text()
    assert len(re.findall(r'<img [^>]*src="data:image/png;base64,', page)) == 5  # signal, PSD, fit, ACF, Bode
    for caption in ("free-decay window", "Welch PSD", "Time-domain fit", "Residual autocorrelation", "Bode plot"):
        assert caption in page
    assert page.count("<table>") == 4  # sampling, parameters, cross-checks, geometric prior
    for text in (
        "timestamp jitter",
        "95 % low",
        "Hilbert envelope",
        "logarithmic decrement",
        "half-power",
        "identified/prior",
        "verdict-uncertain",
        "Damping (zeta, d)",
    ):
        assert text in page
    data = json.loads(out.read_text())
    assert set(data) >= {
        "sloshid_version",
        "sources",
        "window_s",
        "quality",
        "reasons",
        "parameters",
        "transfer_function",
        "psd",
        "cross_checks",
        "fit",
        "prior",
    }
    assert set(data["parameters"]) == {"f_hz", "omega_rad_s", "zeta", "l_m", "d_ns_per_m", "m_kg"}
    # the measured file's content, by which validate knows a run the model was fitted on from any working directory
    assert data["source_sha256"] == [file_sha256(data["sources"][0])]
    assert data["prior"]["f_hz"] == pytest.approx(F_PHYS, abs=0.001)
    assert "f_hz" in stdout and "95 % CI" in stdout and "frequency (f, omega, l): good" in stdout


def test_a_band_that_misses_the_mode_says_so_once(antisloshing_dir):
    # --f-range 3.5,5 on a 3.0 Hz run: the fit left the band for the 3.01 Hz mode, and the verdict also called that
    # same mode a "strong second mode at 3.01 Hz (13162 % of the main peak)" and "a strong mode below the reported
    # 3.011 Hz", and fitted it as a second mode beside itself
    sig = load_signal(antisloshing_dir / "slosh" / "LE_2D_0m_5s_900deg.mat")
    res = Identifier(f_range_hz=(3.5, 5.0)).fit(sig).result
    reasons = res.groups["frequency"].reasons
    assert res.groups["frequency"].quality == "unreliable"
    assert any("lies outside the searched band 3.5-5 Hz" in r for r in reasons)
    f = res.parameters["f_hz"].value
    assert not any(re.search(rf"mode at {f:.3g} Hz", r) or "lies below the reported" in r for r in reasons), reasons
    assert res.second_mode is None or abs(res.second_mode.peak.f_hz - f) > 0.16  # not the fitted mode again


def test_the_residual_autocorrelation_is_drawn_past_the_correction_it_marks(antisloshing_dir):
    # on this run the interval correction reaches 139 lags (2.3 s) while the plot stopped at 60 (1 s), so the
    # correlation it corrects for was never shown (a trial)
    import matplotlib.pyplot as plt

    res = Identifier(mass_kg=0.59).fit(load_signal(antisloshing_dir / "slosh" / "Tilt_RD_2D_0.3m_7s_30deg.mat")).result
    ax = res.plot_residual_acf()
    reach = next(line for line in ax.get_lines() if line.get_label() == "interval correction reach").get_xdata()[0]
    drawn = max(seg[:, 0].max() for seg in ax.collections[0].get_segments())
    assert res.fit.hac_lags[0] > 3 * res.lb_lags[0] and drawn >= reach
    plt.close("all")
