"""Score sloshid's plan against the usual alternatives on the same move, liquid and limits.

Builds the constant-acceleration profile, ZV/ZVD input shaping, ruckig jerk-limited moves (upright and
tilt-compensated), sloshid's plan and its robust variant, and camera feedback on top of the first and of the
plan; scores each by the nonlinear liquid's angle relative to the container (transfer time s, peak during
the move deg, residual after arrival deg, tilt deg and deg/s, robot and move limits), runs the closed-loop,
robustness (frequency +-20 %, damping x0.5..x2) and camera-rate studies, and prints a verdict. Tune it in
the scenario's [compare] table (keys: docs/guides/compare.md). A move within a spill margin is scored on the margin
instead, ranked by its risk of breaking it. Exit code 1 when -o is given but no method is recommended: nothing is
written (a file already at TRAJ.csv is left as it was), and a script that sends the move should stop there.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from typing import TYPE_CHECKING

from sloshid.cli.plan_cmd import arm_clause, fit_command, note_io_model, predict_command, warn_doubtful_parameters
from sloshid.comparison.recommend import declare_move, joints_path
from sloshid.core.outputs import Outputs

if TYPE_CHECKING:
    from sloshid.planning.arm import ArmFit


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid compare`."""
    parser.add_argument(
        "scenario",
        metavar="SCENARIO.toml",
        help="scenario file as for `sloshid plan` (move, limits in m, m/s, m/s^2, deg; optional [compare])",
    )
    parser.add_argument(
        "--params",
        metavar="PARAMS.json",
        default=None,
        help="liquid parameters from `sloshid identify` (omega in rad/s, zeta); default: the scenario's [liquid]",
    )
    parser.add_argument(
        "--report", metavar="DIR", default=None, help="write the HTML report to DIR/index.html (figures embedded)"
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="TRAJ.csv",
        default=None,
        help="write the recommended move as a 1 kHz robot trajectory CSV (the columns of `sloshid plan -o`) and "
        "TRAJ.json beside it (which method, why, and the frequency band in Hz it holds over, or within a spill margin "
        "its risk of breaking it); with a [robot] arm the fastest move the arm can follow (sloshid's plan slowed for "
        "it when needed, unless [robot] fit_joints = false) and its joints in TRAJ_joints.csv (t_s, q1..q7 in rad); "
        "nothing, and exit code 1, when none is recommended",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the full summary as JSON (times in s, angles in deg) instead of the table",
    )


def run(args: argparse.Namespace) -> int:
    """Load and validate everything first (nothing is written on bad input), compare, then write outputs."""
    from sloshid.comparison.compare import compare_scenario
    from sloshid.model.pendulum import IdentifiedFrequency
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    inputs = [p for p in (args.scenario, args.params) if p]
    outputs = Outputs(inputs)
    report_dir = outputs.report_dir(args.report, "--report") if args.report is not None else None
    output = (
        declare_move(outputs, args.output, "-o", "choose another -o, or move that file away")[0]
        if args.output
        else None
    )
    scenario = load_scenario(args.scenario)
    if scenario.within_margin:
        return _run_upright(args, scenario, inputs, output, report_dir)
    params = resolve_liquid(scenario, args.params)
    note_io_model(args.params, "TRAJ.csv")
    warn_doubtful_parameters(args.params, scenario)
    interval = IdentifiedFrequency.from_identify_json(args.params).ci95_hz if args.params else None
    comp = compare_scenario(scenario, params, f_interval_hz=interval, progress=sys.stderr.isatty())
    if report_dir is not None:
        print(f"report written to {comp.report(report_dir, progress=sys.stderr.isatty())}", file=sys.stderr)
    print(json.dumps(comp.to_dict(), indent=2) if args.json else comp.summary())
    # with none recommended, the next line says why nothing was written (the library would refuse it)
    written = comp.write_recommended(output, tuple(inputs)) if output is not None and comp.recommended else None
    arm, peak, rec, sent = None, None, comp.recommended, comp.recommended_trajectory()
    if written is not None and rec is not None and sent is not None:  # checked on the scenario's arm and whole model
        found = comp.arm_objection(scenario.arm)
        if found is not None:
            command = fit_command(args.scenario, args.params, rec.key == "sloshid_robust", "TRAJ.csv")
            arm = arm_clause(found.reason, found.refit, command)
        if args.params:  # an input-output model: what its whole model says (None for a plain one)
            from sloshid.validation.predict import whole_model_peak_deg

            peak = whole_model_peak_deg(args.params, sent, str(written))
    return _end(args, comp, output, written, arm, peak, comp.recommendation.arm if comp.recommendation else None)


def _run_upright(args, scenario, inputs: list, output, report_dir) -> int:
    """Scenarios within a spill margin (upright, or tilting on a straight [move]): sloshid's plans within the margin
    against the upright baselines, ranked by risk;
    -o writes the first-ranked move that meets the margin."""
    from sloshid.comparison.upright_compare import compare_upright
    from sloshid.planning.scenario import resolve_liquid

    liquid = resolve_liquid(scenario, args.params) if (args.params or scenario.liquid is not None) else None
    comp = compare_upright(scenario, liquid, params_path=args.params)
    page = comp.report_page() if report_dir is not None else None  # drawn before anything is written
    written = comp.write_first(output, tuple(inputs)) if output is not None else None
    if page is not None:
        print(f"report written to {page.save(report_dir)}", file=sys.stderr)
    print(json.dumps(comp.to_dict(), indent=2) if args.json else f"{comp.summary()}\n\n{comp.verdict}")
    return _end(args, comp, output, written)


def _end(args, comp, output, written, arm: str | None = None, peak: float | None = None, fit=None) -> int:
    """The next line (on stderr under --json, which stays JSON; `arm`, `peak` and `fit` as `next_line` takes them);
    exit code 1, and a line saying nothing was written, when -o was asked for but no method is recommended."""
    given = shlex.join([args.scenario] + (["--params", args.params] if args.params else []))
    line = next_line(comp, given, written, arm, args.params, peak, fit)
    print(line, file=sys.stderr if args.json else sys.stdout)
    if output is None or written is not None:
        return 0
    kept = f"; {output} was left as it was, not this comparison's move" if output.exists() else ""
    print(f"sloshid: no method is recommended, so nothing was written{kept}.", file=sys.stderr)
    return 1


def next_line(
    comp,
    scenario: str,
    written,
    arm: str | None = None,
    params: str | None = None,
    peak: float | None = None,
    fit: ArmFit | None = None,
) -> str:
    """What to do with the result: send the written move (and its joints when the scenario's arm follows it: `fit`;
    not when the whole input-output model `params` moves the liquid in it by `peak` deg, past what the comparison calls
    slosh-free, nor when the scenario's arm cannot follow it: `arm`, why and what to do), or the command that writes it
    (`scenario`: the scenario and --params as given)."""
    rec = comp.recommended
    if rec is None:
        return "next: no method is recommended (see why above); change the move, its limits or [compare] and compare again."
    if written is not None and peak is not None and params is not None and peak > comp.settings.peak_ok_deg:
        return (
            f"next: do not send {written} ({rec.label}): by the whole model of {params} it moves the liquid by up to "
            f"{peak:.2g} deg (the comparison, with its f and zeta alone, calls a move slosh-free within "
            f"{comp.settings.peak_ok_deg:g} deg); check a move with {predict_command(written, params)} and "
            "send one it keeps slosh-free."
        )
    if written is not None and arm is not None:
        return f"next: do not send {written} ({rec.label}): {arm}."
    follows = fit is not None and fit.follows
    slowed = f", slowed for the arm from {fit.first_s:.3f} s" if fit is not None and fit.slowed else ""
    if written is not None:
        joints = f" (or the joints, {joints_path(written)})" if follows else ""
        return (
            f"next: send {written}{joints} to the robot ({rec.label}{slowed}; {written.with_suffix('.json')} says why)."
        )
    if rec.key == "sloshid_robust" and fit is None:
        return f"next: sloshid plan {scenario} --robust -o TRAJ.csv writes the recommended move ({rec.label})."
    what = f"the recommended move ({rec.label}{slowed})" + " and its joints" * follows
    return f"next: sloshid compare {scenario} -o TRAJ.csv writes {what}."
