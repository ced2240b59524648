"""Plan a time-optimal, slosh-free container move (seed section III, CasADi + IPOPT) and write it as a 1 kHz
robot trajectory CSV. The container follows the liquid's surface, so the liquid never moves relative to it.
The plan is checked against the robot's Cartesian limits and verified by simulating the liquid independently.
Exit code 1 when a limit is exceeded, the verification fails, the path is left or the arm cannot follow: the files are
written for inspection (when none of them is there yet: a good plan's are kept), but a script that runs plans should
stop there.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from pathlib import Path

from sloshid.cli.settings_options import add_settings, settings_from
from sloshid.core.errors import UserError
from sloshid.core.outputs import FIGURE_MARK, Outputs
from sloshid.planning.arm_settings import ArmSettings
from sloshid.planning.plan_settings import PlanSettings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid plan`."""
    parser.add_argument(
        "scenario",
        help="scenario TOML: [move] start/goal (m) or waypoints, [limits], "
        "[[obstacles]], [container], [solver], [liquid], [robot] (see docs/guides/plan.md)",
    )
    parser.add_argument(
        "--params",
        metavar="PARAMS.json",
        default=None,
        help="liquid parameters written by `sloshid identify` (omega in rad/s, zeta, m in kg); "
        "overrides the scenario's [liquid] table",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="TRAJ.csv",
        required=True,
        help="robot trajectory at 1 kHz: time (s), position (m), velocity (m/s), acceleration "
        "(m/s^2), Euler angles (rad), angular velocity (rad/s), quaternion",
    )
    parser.add_argument(
        "--report",
        metavar="DIR",
        default=None,
        help="write an HTML report (states over time, 3-D path, limit usage, verification) to DIR",
    )
    parser.add_argument(
        "--joints",
        metavar="JOINTS.csv",
        default=None,
        help="also write the arm's joint angles at 1 kHz (t_s, q1..q7 in rad) by inverse kinematics, checked "
        "against the datasheet's joint position, velocity, acceleration and jerk limits; needs a [robot] table "
        'with model = "panda"; exit code 1 when the arm cannot follow (the files are still written where none is yet); '
        "without it a [robot] arm is checked all the same, for the last line only (send the plan, or why not)",
    )
    add_settings(parser, ArmSettings, only=("fit_joints",), title="the scenario's [robot] arm (with --joints)")
    add_settings(parser, PlanSettings)
    parser.add_argument(
        "--json",
        action="store_true",
        help="print a JSON summary on stdout: a slosh-free plan's T_s in s, solve_time_s in s, iterations, status, "
        "max_tilt_deg, max_tilt_rate_deg_s, limits_ok, verification, per-segment figures; a plan within a spill "
        "margin's kind, T_s, max_tilt_deg, status, containers (peak and residual wall heights in mm against their "
        "allowances), limiting_container, verification_ok, limits_ok, risk, robust and margin_sweep",
    )


def run(args: argparse.Namespace) -> int:
    """Check every output, load, plan, then write the CSV, joints and report only after everything succeeded;
    exit code 1 when the arm cannot follow, a limit is exceeded, the verification fails or the path is left (the
    files are still written, for inspection, when none of them is there yet)."""
    from sloshid.planning.planner import plan
    from sloshid.planning.result import PlanResult
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    settings = settings_from(args, PlanSettings)
    if args.fit_joints and not args.joints:
        raise UserError("--fit-joints needs --joints JOINTS.csv.")
    scenario = load_scenario(args.scenario)
    table = scenario.path_table
    path_csv = [scenario.path.source] if scenario.path is not None and table is not None and table.points_csv else []
    outputs = Outputs([p for p in (args.scenario, args.params, *path_csv) if p])
    output = outputs.file(args.output, "-o", (".csv",))
    joints = outputs.file(args.joints, "--joints", (".csv",)) if args.joints else None
    report_dir = outputs.report_dir(args.report, "--report") if args.report else None
    if joints is not None and scenario.arm is None:
        raise UserError(
            '--joints needs a [robot] table with model = "panda" in the scenario (base_xyz_m and q_start are optional).'
        )
    if scenario.within_margin:
        return _run_upright(args, settings, scenario, outputs, output, report_dir)
    if settings.sweep_margin is not None:
        raise UserError(
            "--sweep-margin plans moves within a spill margin: the scenario needs [limits] spill_margin_mm on one "
            "straight [move] (upright with tilt_max_deg = 0, or tilting)."
        )
    if scenario.limits.spill_margin_mm is not None and scenario.path is None:
        print(
            "sloshid: note: [limits].spill_margin_mm is planned with tilt for one straight start and goal without "
            "obstacles; this move (waypoints or obstacles) keeps the liquid level with the container instead, which "
            "holds any margin the verification below holds.",
            file=sys.stderr,
        )
    if settings.robust:
        from sloshid.comparison.compare import robust_scenario

        scenario = robust_scenario(scenario)
    params = resolve_liquid(scenario, args.params)
    warn_doubtful_parameters(args.params, scenario)
    result = plan(scenario, params, progress=sys.stderr.isatty())
    assert isinstance(result, PlanResult)  # a move within a spill margin went to _run_upright above
    fit = []
    if joints is not None:
        result, fit = _check_joints(result, scenario, params, args.fit_joints or scenario.arm.fit_joints)
    peak = note_io_model(args.params, str(output), result.trajectory)  # of the plan written (re-planned for joints)
    executable = result.joints is None or result.joints.executable
    passed = executable and result.limits_ok and result.verification_ok and result.path_ok
    # a plan that fails its checks is written for inspection, but never over a file already there (a good plan): then
    # none of its outputs is, so that no failed file sits beside a kept one
    report_page = report_dir / "index.html" if report_dir is not None else None
    kept = [] if passed else [p for p in (output, joints, report_page) if p is not None and p.exists()]
    page = None
    if report_dir is not None and not kept:  # drawn before anything is written
        source = f"identify's {args.params}" if args.params else f"the [liquid] table of {args.scenario}"
        csv = os.path.relpath(os.path.abspath(output), os.path.abspath(report_dir))
        page = result.report_page({"trajectory CSV": csv}, liquid_source=source)
    written = [] if kept else [p for p in (output, joints) if p is not None]
    if written:
        result.trajectory.to_csv(output)
        if joints is not None and result.joints is not None:
            result.joints.write_csv(joints)
    if page is not None:
        page.save(report_dir)
    _warnings(result, fit)
    if args.json:
        summary = result.to_dict()
        if fit and summary["joints"] is not None:
            summary["joints"]["fit"] = [vars(f) for f in fit]
        print(json.dumps(summary, indent=2))
    else:
        print(result.summary() + (f"; wrote {' and '.join(map(str, written))}" if written else ""))
    if written and passed:  # the one line a user needs next (on stderr under --json, which stays JSON)
        objection = None
        if joints is None and scenario.arm is not None:  # the arm the scenario names, checked all the same
            objection = arm_says(scenario.arm, result.trajectory, args.scenario, args.params, settings.robust, output)
        step = next_step(output, joints, args.params, peak, result.verify_during_deg, objection)
        print(step, file=sys.stderr if args.json else sys.stdout)
    if kept:
        print(
            f"sloshid: kept {' and '.join(map(str, kept))}: a plan that fails its checks does not replace a file "
            "already there, and so writes none of its files; write them to new paths to inspect them.",
            file=sys.stderr,
        )
    if result.joints is not None and not result.joints.executable:
        why = result.joints.reason().rstrip(".")
        print(
            f"sloshid: not executable on the Panda: {why}{'' if fit else _fit_cost(result, scenario, params)}.",
            file=sys.stderr,
        )
        return 1
    # a plan past a limit, unverified or off its path is written for inspection, but a script must not run it
    return 0 if result.limits_ok and result.verification_ok and result.path_ok else 1


def _run_upright(args, settings: PlanSettings, scenario, outputs, output: Path, report_dir: Path | None) -> int:
    """A move within the spill margin (upright, or tilting: `Scenario.within_margin`): plan (robust with --robust), its
    risk, an optional margin sweep;
    exit code 1 when a margin or limit is broken in the independent simulation (the files are still written where
    none is yet)."""
    from sloshid.api import plan_upright_scenario
    from sloshid.planning.upright import sweep_margin

    if args.joints:
        if scenario.limits.upright:
            raise UserError(
                "--joints takes tilting moves of a [robot] arm; an upright move (tilt_max_deg = 0) has no arm."
            )
        raise UserError(
            "--joints takes slosh-free moves so far; a move within a spill margin (spill_margin_mm) is planned without "
            "the arm: drop --joints, or drop spill_margin_mm to plan the slosh-free move for the arm."
        )
    margins = settings.margins_mm() or None
    figure = (
        outputs.file(
            output.with_name(output.stem + "_margin_sweep.png"),
            "--sweep-margin's picture",
            (".png",),
            (FIGURE_MARK, "choose another -o, or move that file away"),
        )
        if margins
        else None
    )
    result = plan_upright_scenario(scenario, args.params, settings.robust)
    liquid = result.vessels[0].liquid if not scenario.containers else None
    samples = result.guarantee.samples if result.guarantee is not None else None
    sweep = sweep_margin(scenario, liquid, margins, args.params, samples) if margins else None
    passed = result.verification_ok and result.limits_ok
    report_page = report_dir / "index.html" if report_dir is not None else None
    kept = [] if passed else [p for p in (output, report_page) if p is not None and p.exists()]
    page = None
    if report_dir is not None and not kept:
        csv = os.path.relpath(os.path.abspath(output), os.path.abspath(report_dir))
        page = result.report_page({"trajectory CSV": csv})
    if not kept:
        result.to_csv(output)
    if sweep is not None and figure is not None:
        sweep.save_figure(figure)
    if page is not None:
        page.save(report_dir)
    if args.json:
        summary = result.to_dict()
        summary["margin_sweep"] = sweep.to_dict() if sweep is not None else None
        print(json.dumps(summary, indent=2))
    else:
        print(result.summary())
        if sweep is not None:
            print(sweep.summary() + f"; drew {figure}")
        print(
            f"wrote {output}"
            if not kept
            else f"sloshid: kept {output}: a plan that breaks its margin does not replace it."
        )
    if not passed:
        broken = [c.name for c in result.checks if not c.ok]
        print(
            f"sloshid: warning: {', '.join(broken) or 'a limit'} broken in the independent simulation; raise [solver].N.",
            file=sys.stderr,
        )
    return 0 if passed else 1


def predict_command(trajectory: str | Path, params: str | Path) -> str:
    """The `sloshid predict` line that checks a written move by the whole input-output model, runnable as printed."""
    move = Path(trajectory)
    out = move.with_name(move.stem + "_prediction.csv")
    return f"`{shlex.join(['sloshid', 'predict', str(move), '--params', str(params), '-o', str(out)])}`"


def note_io_model(params_path: str | None, trajectory: str, planned=None) -> float | None:
    """One stderr note when the parameters are an input-output model, whose gains plan and compare do not use (with
    how far it moves the liquid in the `planned` trajectory, when given); that peak (deg), or None."""
    if not params_path:
        return None
    from sloshid.validation.predict import planning_note, whole_model_peak_deg

    peak = whole_model_peak_deg(params_path, planned, trajectory) if planned is not None else None
    note = planning_note(params_path, trajectory, peak)
    if note:
        check = predict_command(trajectory, params_path)
        print(f"sloshid: note: {note.removesuffix('.')} ({check}).", file=sys.stderr)
    return peak


def next_step(
    output: Path,
    joints: Path | None,
    params_path: str | None,
    peak_deg: float | None,
    limit: float,
    arm: str | None = None,
) -> str:
    """The line a user needs after a plan that passed its checks: send it; but not when the whole input-output model
    moves the liquid in it by more than the plan is verified to (`peak_deg` against `limit`, deg): then check first;
    nor when the scenario's arm cannot follow it (`arm`: `arm_objection`'s clause)."""
    if peak_deg is not None and params_path is not None and peak_deg > limit:
        return (
            f"next: do not send {output}: by the whole model of {params_path} it moves the liquid by up to "
            f"{peak_deg:.2g} deg (the plan holds its pendulum pair within {limit:g} deg); check a move with "
            f"{predict_command(output, params_path)} and send one it keeps slosh-free."
        )
    if arm is not None:
        return f"next: do not send {output}: {arm}."
    also = f" (or the joints, {joints})" if joints is not None else ""
    return f"next: send {output}{also} to the robot."


def fit_command(scenario: str | Path, params_path: str | Path | None, robust: bool, output: str | Path) -> str:
    """The `sloshid plan` command that plans the move for the scenario's arm: --joints beside `output`, --fit-joints."""
    out = Path(output)
    given = [str(scenario)] + (["--params", str(params_path)] if params_path else []) + ["--robust"] * robust
    from sloshid.comparison.recommend import joints_path

    return shlex.join(["sloshid", "plan", *given, "-o", str(out), "--joints", str(joints_path(out)), "--fit-joints"])


def arm_says(arm, traj, scenario: str | Path, params_path: str | Path | None, robust: bool, output) -> str | None:
    """Why the scenario's `arm` (its ArmSettings) cannot follow the move `traj` written to `output`, with the command
    that plans one it can (`arm_clause`); None when it can follow it."""
    from sloshid.planning.arm import arm_objection

    found = arm_objection(traj, arm)
    if found is None:
        return None
    return arm_clause(found.reason, found.refit, fit_command(scenario, params_path, robust, output))


def arm_clause(reason: str, refit: bool, command: str) -> str:
    """Why the scenario's arm cannot follow a move (`planning.arm.ArmObjection`) and, when a slower plan can fix it
    (`refit`), the `command` that plans one: the clause after "do not send TRAJ.csv"."""
    if not refit:
        return reason
    return f"{reason}; `{command}` plans sloshid's move slower until the arm can follow it, and writes its joints"


def warn_doubtful_parameters(params_path: str | None, scenario) -> None:
    """One stderr line per parameter a plan or comparison uses (f, zeta) whose identify verdict is not good: why,
    and what it costs (the band the recommendation must hold over; the damping the move was made for)."""
    from sloshid.comparison.compare import CompareSettings
    from sloshid.comparison.recommend import frequency_band
    from sloshid.core.errors import SMALL_FILE_BYTES, read_input
    from sloshid.model.pendulum import IdentifiedFrequency, SloshParams

    if not params_path:
        return
    params = SloshParams.from_identify_json(params_path)  # checks the file first
    freq = IdentifiedFrequency.from_identify_json(params_path)
    zeta = json.loads(read_input(params_path, "parameter file", SMALL_FILE_BYTES)).get("parameters", {}).get("zeta", {})
    because = lambda reasons: f" ({reasons[0].rstrip('.')})" if reasons else ""  # noqa: E731
    if freq.quality not in (None, "good"):
        margin = float(scenario.compare.get("frequency_margin", CompareSettings().frequency_margin))
        (lo, hi), _ = frequency_band(params.f_hz, freq.ci95_hz, margin)
        print(
            f"sloshid: warning: the identified frequency is {freq.quality}{because(freq.reasons)}; it costs: a move "
            f"must stay slosh-free over {lo:.3g}-{hi:.3g} Hz (compare's band), where one planned for "
            f"{params.f_hz:.3g} Hz alone may not (--robust plans for -10 % to +10 %).",
            file=sys.stderr,
        )
    if zeta.get("quality") not in (None, "good"):
        print(
            f"sloshid: warning: the identified damping ratio is {zeta['quality']}{because(zeta.get('reasons'))}; it "
            f"costs: the move is made for zeta = {params.zeta:.3g}, and compare's robustness sweep shows what half or "
            "twice that leaves behind.",
            file=sys.stderr,
        )


def _check_joints(result, scenario, params, fit_joints: bool) -> tuple:
    """Inverse kinematics and joint limits on the plan, re-planned slower with --fit-joints when the arm cannot
    follow; (the plan with its joint check, the fit attempts)."""
    from sloshid.planning.arm import check_joints, fit_to_joints

    check = check_joints(result.trajectory, scenario.arm)
    fit = []
    if fit_joints and not check.executable:
        result, check, fit = fit_to_joints(scenario, params, result, check)
    result.joints = check
    return result, fit


def _fit_cost(result, scenario, params) -> str:
    """What --fit-joints would cost, measured by fitting (the plan written stays the fastest one)."""
    from sloshid.planning.arm import fit_to_joints

    _, check, steps = fit_to_joints(scenario, params, result, result.joints)
    if not check.executable:
        return f"; --fit-joints cannot fix it: {steps[-1].reason.rstrip('.')}"
    cost = 100 * (steps[-1].T_s / steps[0].T_s - 1)
    return (
        f"; --fit-joints (or [robot] fit_joints = true) re-plans slower until it can: T {steps[0].T_s:.3f} -> "
        f"{steps[-1].T_s:.3f} s (+{cost:.1f} %)"
    )


def _warnings(result, fit: list) -> None:
    """Robot limits exceeded, a failed verification, a path left, and joint re-planning, one line each."""
    from sloshid.planning.result import VERIFY_AFTER_DEG

    for usage in result.limits:
        if not usage.ok:
            print(
                f"sloshid: warning: robot limit {usage.quantity} exceeded: peak {usage.peak:.4g} > {usage.limit:.4g} "
                f"at t = {usage.t_peak_s:.3f} s.",
                file=sys.stderr,
            )
    for usage in result.move_limits:
        if not usage.ok:
            print(
                f"sloshid: warning: [limits].{usage.quantity} exceeded: peak {usage.peak:.4g} > {usage.limit:.4g} at "
                f"t = {usage.t_peak_s:.3f} s (the solver holds it at its grid points, and solving again with it "
                "lowered did not bring the peak under it; a larger [solver].N holds it closer).",
                file=sys.stderr,
            )
    v = result.verification
    if not result.verification_ok:
        print(
            f"sloshid: warning: verification failed: liquid-container angle {v.peak_during_deg:.3g} deg during the "
            f"move (limit {result.verify_during_deg:g}) and {v.residual_deg:.3g} deg after (limit {VERIFY_AFTER_DEG}); "
            "a finer grid ([solver].N, e.g. 400 for a long move) usually verifies.",
            file=sys.stderr,
        )
    if result.max_path_deviation_m is not None and not result.path_ok:
        print(
            f"sloshid: warning: the trajectory leaves the path by {result.max_path_deviation_m * 1e3:.3f} mm, more "
            f"than [path].path_tolerance_m = {result.path_tolerance_m * 1e3:g} mm.",
            file=sys.stderr,
        )
    if result.joints is not None and result.joints.start_moved:
        print(f"sloshid: {result.joints.start_moved}", file=sys.stderr)
    if len(fit) > 1:
        print(
            f"sloshid: re-planned {len(fit) - 1} time(s) with lower Cartesian limits for the joints: T "
            + " -> ".join(f"{f.T_s:.3f}" for f in fit)
            + f" s (+{100 * (fit[-1].T_s / fit[0].T_s - 1):.1f} %).",
            file=sys.stderr,
        )
