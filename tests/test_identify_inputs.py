"""Reading signals (tracker CSV, any CSV, .mat) and refusing every bad input of issue 3 with one sentence."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from sloshid.identification.signals import load_signal
from sloshid.synthetic.decays import free_decay


def _csv(path, header, t, y, sep=","):
    """Write a plain two-column CSV."""
    lines = ([sep.join(header)] if header else []) + [f"{a:.6f}{sep}{b:.6f}" for a, b in zip(t, y)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def decay():
    """A clean 10 s, 60 fps decay at 3 Hz."""
    return free_decay(3.0, 0.03, 60, amplitude=5, seed=2)


def test_generic_csv_semicolon_and_indices(tmp_path, decay):
    t, y = decay
    path = _csv(tmp_path / "x.csv", None, t, y, sep=";")  # no header: columns by index, delimiter sniffed
    sig = load_signal(path, time_col="0", value_col="1")
    assert sig.t_s.size == t.size and sig.value[5] == pytest.approx(y[5], abs=1e-6)
    named = _csv(tmp_path / "n.csv", ["time", "h_mm", "other"], t, y)
    named.write_text(named.read_text().replace("\n", ",0\n").replace("h_mm,0", "h_mm", 1))
    sig = load_signal(named, value_col="h_mm")
    assert sig.unit == "mm" and sig.label == "h_mm"


def test_mat_defaults_and_named_variables(tmp_path, decay):
    t, y = decay
    scipy.io.savemat(tmp_path / "a.mat", {"slosh_times": t[None, :], "slosh_heights": y[None, :]})
    sig = load_signal(tmp_path / "a.mat")
    assert sig.unit == "mm" and sig.value.size == y.size
    scipy.io.savemat(tmp_path / "b.mat", {"tt": t, "phi_rad": y})
    sig = load_signal(tmp_path / "b.mat", time_var="tt", value_var="phi_rad")
    assert sig.unit == "rad"


def test_few_nan_dropped_with_warning(tmp_path, decay, run_cli):
    t, y = decay
    y = y.copy()
    y[[10, 200, 400]] = np.nan
    path = _csv(tmp_path / "s.csv", ["t_s", "angle_deg"], t, y)
    out = tmp_path / "p.json"
    code, _, err = run_cli("identify", path, "-o", out)
    assert code == 0 and out.exists()
    assert "dropped 3 NaN/inf samples" in err


def test_a_tracker_csvs_wall_column_is_read_on_its_valid_rows(tmp_path, decay):
    # a surface track's wall heights are NaN (or stale) where valid == 0, as its angle is: any measured column is read
    # on the valid rows; the smoothed angle, which bridges the others, is read whole
    t, y = decay
    valid = np.ones(t.size, int)
    valid[[3, 50, 51, 52, 300]] = 0
    wall = np.where(valid == 1, 2 * y, np.nan)
    wall[[50, 51, 52]] = 2 * y[49]  # a repeated picture: the last fresh value again, stale
    header = "frame,t_s,angle_deg,angle_smoothed_deg,quality,valid,left_wall_px"
    rows = [f"{k},{a:.6f},{b:.6f},{b:.6f},1.0,{v},{w:.6f}" for k, (a, b, v, w) in enumerate(zip(t, y, valid, wall))]
    path = tmp_path / "track.csv"
    path.write_text("\n".join([header, *rows]) + "\n")
    sig = load_signal(path, value_col="left_wall_px")
    assert sig.t_s.size == t.size - 5 and np.isfinite(sig.value).all() and sig.tracked
    np.testing.assert_allclose(sig.value, 2 * y[valid == 1], atol=1e-5)
    assert load_signal(path, value_col="angle_smoothed_deg").t_s.size == t.size


def _bad_cases(tmp_path, decay):
    """(name, argv tail, expected message fragment) for every bad input the issue names."""
    t, y = decay
    cases = []
    cases.append(("missing", [tmp_path / "nope.csv"], "does not exist"))
    p = _csv(tmp_path / "cols.csv", ["t_s", "a", "b"], t, y)
    p.write_text(p.read_text().replace("\n", ",1\n").replace("a,b,1", "a,b", 1))
    cases.append(("unknown column", [p, "--value-col", "angle"], "no value column 'angle'; available: t_s, a, b"))
    scipy.io.savemat(tmp_path / "v.mat", {"slosh_times": t, "slosh_heights": y})
    cases.append(
        (
            "unknown variable",
            [tmp_path / "v.mat", "--value-var", "h"],
            "no variable 'h'; it has: slosh_heights, slosh_times",
        )
    )
    p = _csv(tmp_path / "text.csv", ["t_s", "angle_deg"], t, y)
    lines = p.read_text().splitlines()
    lines[20] = f"{t[19]:.6f},abc"
    p.write_text("\n".join(lines) + "\n")
    cases.append(("non-numeric", [p], "holds 'abc', which is not a number"))
    yy = y.copy()
    yy[: int(0.6 * yy.size)] = np.inf
    cases.append(("mostly inf", [_csv(tmp_path / "inf.csv", ["t_s", "angle_deg"], t, yy)], "too many to identify from"))
    tt = t.copy()
    tt[100] = tt[99]
    cases.append(
        (
            "time repeats",
            [_csv(tmp_path / "rep.csv", ["t_s", "angle_deg"], tt, y)],
            "not strictly increasing at sample 100",
        )
    )
    short = slice(0, 45)  # 0.75 s at 60 fps: 2.2 periods of 3 Hz
    cases.append(
        (
            "short",
            [_csv(tmp_path / "short.csv", ["t_s", "angle_deg"], t[short], y[short])],
            "lasts only 2.15 periods of the 2.95 Hz mode; at least 3 are needed",  # two decimals, rounded down
        )
    )  # coarse guess from 0.75 s
    # scaled out of any measurement's range: tracebacks (a NaN to an integer, a division by zero, infs in a fit)
    for name, scale, message in (
        ("huge", 1e300, "reaches 5.3e+300, no angle"),
        ("large", 1e100, "reaches 5.3e+100, no angle"),
        ("tiny", 1e-300, "nothing moved in it"),
    ):
        path = _csv(tmp_path / f"{name}.csv", ["t_s", "angle_deg"], t, y * scale)
        cases.append((name, [path], message))
    ok = _csv(tmp_path / "ok.csv", ["t_s", "angle_deg"], t, y)
    cases.append(("window outside", [ok, "--window", "2,30"], "reaches beyond the data"))
    cases.append(("window reversed", [ok, "--window", "5,2"], "must be before its end"))
    cases.append(("zero mass", [ok, "--mass", "0"], "--mass must be a positive number"))
    cases.append(("negative mass", [ok, "--mass", "-0.5"], "--mass must be a positive number"))
    cases.append(("constant", [_csv(tmp_path / "flat.csv", ["t_s", "angle_deg"], t, np.ones_like(y))], "is constant"))
    rng = np.random.default_rng(0)
    cases.append(
        (
            "noise",
            [_csv(tmp_path / "noise.csv", ["t_s", "angle_deg"], t, rng.normal(size=t.size))],
            "no oscillatory mode found",
        )
    )
    # a slow sway larger than the swing while the mode still rings at the end: with no quiet tail to tell a sway from
    # forcing, it is forcing (a ring-down that fades is fitted with a swaying zero: test_identify)
    _, ringing = free_decay(3.0, 0.005, 60, amplitude=5, seed=2)
    sway = _csv(tmp_path / "sway.csv", ["t_s", "angle_deg"], t, ringing + 3 * np.sin(2 * np.pi * 0.4 * t))
    cases.append(
        (
            "sway",
            [sway],
            "is driven (its mean over a period moves by more than half its swing) until 9.58 s of 9.98 s; "
            "give --window (start and end, s)",
        )
    )
    # thresholds out of their range were taken with exit 0 (the help says fewer than 3 periods is an error)
    for value in ("-2", "nan", "1e9"):
        message = "--min-periods must be between 3 and 1000 periods (a window of fewer than 3 is an error in any case)"
        cases.append((f"min periods {value}", [ok, "--min-periods", value], message))
    for value in ("-1", "nan", "2"):
        message = "--second-mode-ratio is a fraction of the dominant PSD peak, above 0 and at most 1"
        cases.append((f"second mode ratio {value}", [ok, "--second-mode-ratio", value], message))
    cases.append(("band to infinity", [ok, "--f-range", "0.5,inf"], "--f-range must be two increasing finite"))
    cases.append(("infinite radius", [ok, *("--container-radius-m", "inf", "--fill-height-m", "0.08")], "finite"))
    cases.append(("half prior", [ok, "--container-radius-m", "0.05"], "needs both"))
    # millimetres typed as metres: the error was that the default band misses a 0.08-0.11 Hz "first mode"
    mm = [ok, "--container-radius-m", "50", "--fill-height-m", "80"]
    cases.append(("geometry in mm", mm, "--container-radius-m must be in metres, at most 10 (0.05 for 50 mm), got 50"))
    # a band above what 60 fps samples resolve: the band's mistake, not the time column's (which was blamed)
    cases.append(
        ("band too high", [ok, "--f-range", "20,40"], "at most 15 Hz at 4 samples per period); lower --f-range")
    )
    return cases


def test_every_bad_input_fails_cleanly(tmp_path, decay, run_cli):
    for name, tail, message in _bad_cases(tmp_path, decay):
        out = tmp_path / f"{name}.json"
        report = tmp_path / f"{name}_report"
        code, _stdout, err = run_cli("identify", *tail, "-o", out, "--report", report)
        assert code == 2, (name, err)
        assert message in err, (name, err)
        assert err.count("\n") == 1 and "Traceback" not in err, (name, err)
        assert not out.exists() and not report.exists(), name
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary leftovers


def test_user_window_is_used_and_reported(tmp_path, decay, run_cli):
    t, y = decay
    path = _csv(tmp_path / "w.csv", ["t_s", "angle_deg"], t, y)
    out = tmp_path / "p.json"
    code, stdout, err = run_cli("identify", path, "-o", out, "--window", "1.5,6")
    assert code == 0, err
    import json

    data = json.loads(out.read_text())
    assert data["window_s"] == [[1.5, 6.0]] and data["window_chosen_by"] == ["user"]
    assert data["parameters"]["f_hz"]["value"] == pytest.approx(3.0, rel=0.003)  # 13 periods, 5 deg vs 0.3 deg
    assert "window 1.50-6.00 s (user)" in stdout


def test_welch_peak_refined_beyond_its_bin_and_uniform_grid_exact_for_lines():
    from sloshid.core.spectrum import to_uniform, welch_spectrum

    rng = np.random.default_rng(0)
    for _ in range(20):
        f = rng.uniform(1, 10)
        t = np.arange(0, 10, 1 / 60)
        s = welch_spectrum(t, np.sin(2 * np.pi * f * t + rng.uniform(0, 6)))
        # the zero-padded bin alone is off by up to 1/32 resolution; the log-parabola brings it to ~1e-4
        assert abs(s.peak_f_hz - f) < 0.002 * s.resolution_hz
        assert abs(s.peak_f_hz - f) <= abs(s.peak_bin_f_hz - f)
        assert s.n_averages == 3 and s.resonant
    t = np.sort(rng.uniform(0, 5, 300))  # uneven timestamps: interpolation must be exact for a straight line
    u = to_uniform(t, 2 * t + 1)
    assert np.allclose(u.value, 2 * u.t_s + 1) and "interpolated" in u.note


def test_an_empty_smoothed_column_names_no_smooth(tmp_path, run_cli):
    # identify --value-col angle_smoothed_deg on a `track --no-smooth` CSV said only "240 of 240 samples ... are NaN"
    t = np.arange(240) / 30
    cols = {"frame": np.arange(240), "t_s": t, "angle_deg": np.sin(2 * np.pi * 2.5 * t), "valid": np.ones(240)}
    cols["angle_smoothed_deg"] = np.full(240, np.nan)
    path = tmp_path / "nosmooth.csv"
    path.write_text(",".join(cols) + "\n" + "\n".join(",".join(f"{c[i]:g}" for c in cols.values()) for i in range(240)))
    code, _, err = run_cli("identify", path, "-o", tmp_path / "p.json", "--value-col", "angle_smoothed_deg")
    assert code == 2 and "with `smooth` off leaves it empty" in err and not (tmp_path / "p.json").exists()


def test_an_empty_wall_mm_column_names_the_diameter(tmp_path, run_cli):
    # identify --value-col left_wall_mm on a surface track without --container-diameter-m said only "NaN"
    t = np.arange(240) / 30
    cols = {"frame": np.arange(240), "t_s": t, "angle_deg": np.sin(2 * np.pi * 2.5 * t), "valid": np.ones(240)}
    cols["left_wall_px"], cols["left_wall_mm"] = np.sin(2 * np.pi * 2.5 * t), np.full(240, np.nan)
    path = tmp_path / "surface.csv"
    path.write_text(",".join(cols) + "\n" + "\n".join(",".join(f"{c[i]:g}" for c in cols.values()) for i in range(240)))
    code, _, err = run_cli("identify", path, "-o", tmp_path / "p.json", "--value-col", "left_wall_mm")
    assert code == 2 and "with `container_diameter_m`" in err and not (tmp_path / "p.json").exists()


def test_the_window_identify_prints_can_be_given_back(tmp_path, decay, run_cli):
    # identify prints its window to 0.01 s, so the end of a record that ends at 9.9833 s reads 9.98 or 9.99; given
    # back with --window, a window ending beyond the data by less than one sample was refused as "outside the data"
    t, y = decay
    path = _csv(tmp_path / "d.csv", ["t_s", "angle_deg"], t, y)
    end = t[-1]
    code, _, err = run_cli("identify", path, "-o", tmp_path / "a.json", "--window", f"0.5,{end + 0.004:.3f}")
    assert code == 0, err
    code, _, err = run_cli("identify", path, "-o", tmp_path / "b.json", "--window", f"0.5,{end + 0.05:.2f}")
    assert code == 2 and "reaches beyond the data" in err  # three samples beyond: a wrong window, still refused
