"""compare's decision: the fastest method slosh-free over the frequency band the user actually knows; plan warns
when the identified frequency is not good."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sloshid.comparison.compare import CompareSettings, MethodResult, Score
from sloshid.comparison.recommend import _static_failure, frequency_band
from sloshid.core.errors import UserError

ROOT = Path(__file__).resolve().parents[1]
DEMO = (ROOT / "data" / "scenarios" / "demo_move.toml").read_text()
LIGHT = """
[compare]
methods = ["constant_acc", "zvd", "sloshid", "sloshid_robust"]
omega_factors = [0.9, 0.95, 1.0, 1.05, 1.1]
zeta_factors = [1.0]
camera_fps_sweep = [30.0]
linearity_acc_m_s2 = [0.5]
settle_s = 1.0
workers = 1
"""


def test_a_plan_past_its_move_limits_between_grid_points_points_to_the_grid():
    # a trial's plan rode tilt_rate_max_deg_s = 120 and passed it by 1 % between grid points: compare ruled it out
    # ("No method stays slosh-free") with nothing on the cure; other methods' failures are said as before
    score = Score(2.0, 0.1, 0.004, 5.0, 121.3, True, ["move tilt_rate_max_deg_s 121 > 120"], False)
    plan = MethodResult("sloshid", "sloshid plan", score=score)
    assert _static_failure(plan).endswith("a larger [solver].N holds it closer")
    assert _static_failure(MethodResult("zv", "ZV shaped", score=score)) == (
        "breaks a limit (move tilt_rate_max_deg_s 121 > 120)"
    )


def test_band_is_the_interval_widened_by_the_margin():
    band, source = frequency_band(3.44, (3.40, 3.48), 0.05)
    assert band == pytest.approx((3.40 * 0.95, 3.48 * 1.05))
    assert "identified band 3.4-3.48 Hz" in source  # an interval of f, or the runs' prediction interval
    band, source = frequency_band(3.44, None, 0.05)  # a scenario [liquid] table: nominal +-5 %
    assert band == pytest.approx((3.44 * 0.95, 3.44 * 1.05)) and "nominal" in source
    with pytest.raises(UserError, match="frequency_margin"):
        CompareSettings(frequency_margin=1.5)


@pytest.fixture(scope="module")
def sample_liquid(tmp_path_factory):
    """The bundled sample video tracked and identified (m = 0.5 kg, as pipelines/demo.toml does)."""
    import sloshid

    d = tmp_path_factory.mktemp("sample")
    res = sloshid.identify(sloshid.track(ROOT / "data" / "sample_tap.mp4", float_color="red"), mass_kg=0.5)
    (d / "params.json").write_text(json.dumps(res.to_dict()))
    return d / "params.json", res


@pytest.mark.slow
def test_seed_1d_case_recommends_a_method_slosh_free_over_the_identified_interval(tmp_path, run_cli, sample_liquid):
    params, res = sample_liquid
    lo, hi = res.parameters["f_hz"].ci95
    scenario = tmp_path / "demo.toml"
    scenario.write_text(DEMO[: DEMO.index("[compare]")] + LIGHT)
    code, out, err = run_cli("compare", scenario, "--params", params, "--json")
    assert code == 0, err
    summary = json.loads(out)
    rec = summary["recommendation"]
    assert rec["band_hz"] == pytest.approx([lo * 0.95, hi * 1.05])
    assert rec["method"] is not None, rec["reason"]
    rows = {m["method"]: m for m in summary["methods"]}
    chosen = rows[rec["method"]]
    # the recommended method's slosh-free band (robustness sweep, 5 % steps) must contain the identified interval
    f0 = res.parameters["f_hz"].value
    band = chosen["omega_band_residual_ok"]
    assert band is not None and band[0] * f0 <= lo and hi <= band[1] * f0, (band, lo, hi)
    check = rec["checks"][rec["method"]]
    assert max(check["residual_deg"]) <= 0.5 and max(check["peak_during_deg"]) <= 1.0  # the default thresholds
    # the nominal plan is faster but tolerates no frequency error: it must lose, and the reason says why
    assert rows["sloshid"]["transfer_time_s"] < chosen["transfer_time_s"]
    assert rec["method"] != "sloshid" and "sloshid plan leaves" in rec["reason"]
    assert summary["verdict"].startswith("Recommended: ")


def test_plan_names_each_identified_parameter_that_is_not_good_and_its_cost(tmp_path, run_cli, sample_liquid):
    params, _ = sample_liquid
    data = json.loads(params.read_text())
    data["parameters"]["f_hz"].update(quality="uncertain", reasons=["two strong peaks compete."])
    data["parameters"]["zeta"].update(quality="uncertain", reasons=["the residual is not white."])
    doubtful = tmp_path / "doubtful.json"
    doubtful.write_text(json.dumps(data))
    scenario = tmp_path / "demo.toml"
    scenario.write_text(DEMO[: DEMO.index("[compare]")].replace("N = 100", "N = 40"))
    code, _, err = run_cli("plan", scenario, "--params", doubtful, "-o", tmp_path / "t.csv")
    # it still plans (written; at this coarse N = 40 the plan can pass a robot limit between grid points: exit 1)
    assert (tmp_path / "t.csv").stat().st_size > 0 and code == (1 if "exceeded" in err else 0), err
    warnings = [line for line in err.splitlines() if "identified" in line]
    # each doubtful parameter named, with its reason and what it costs (issue 39): the band a move must hold over
    lo, hi = (f * (1 + m) for f, m in zip(data["parameters"]["f_hz"]["ci95"], (-0.05, 0.05)))
    assert warnings == [
        "sloshid: warning: the identified frequency is uncertain (two strong peaks compete); it costs: a move must "
        f"stay slosh-free over {lo:.3g}-{hi:.3g} Hz (compare's band), where one planned for "
        f"{data['parameters']['f_hz']['value']:.3g} Hz alone may not (--robust plans for -10 % to +10 %).",
        "sloshid: warning: the identified damping ratio is uncertain (the residual is not white); it costs: the move "
        f"is made for zeta = {data['parameters']['zeta']['value']:.3g}, and compare's robustness sweep shows what "
        "half or twice that leaves behind.",
    ]
    code, _, err = run_cli("plan", scenario, "--params", params, "-o", tmp_path / "t2.csv")
    assert code == (1 if "exceeded" in err else 0) and "identified" not in err  # good ones plan silently
