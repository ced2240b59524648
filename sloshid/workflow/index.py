"""The index.html of a pipeline run: one page that summarises every stage and links only files that exist."""

from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Any, NamedTuple

from sloshid.comparison.recommend import slowed_row
from sloshid.identification.estimates import interval_ends, shown_with_error
from sloshid.identification.verdict import PARAMETER_LABELS
from sloshid.report.html import Report
from sloshid.workflow.pipeline import StageRecord


def _link(run_dir: Path, rel: str, text: str) -> str:
    """An <a> to a file of the run, or plain text when the file does not exist."""
    if (run_dir / rel).exists():
        return f'<a href="{html.escape(rel)}">{html.escape(text)}</a>'
    return html.escape(f"{text} (not written)")


def _links(report: Report, run_dir: Path, *links: tuple[str, str]) -> None:
    """One paragraph of links (file of the run, text) to the run's files, separated by dots."""
    report.add_html("<p>" + " · ".join(_link(run_dir, rel, text) for rel, text in links) + "</p>")


def _figure(report: Report, run_dir: Path, stage: str, s: dict[str, Any], caption: str) -> None:
    """Embed the stage's summary figure (a PNG beside its outputs) when it exists, so the page stands alone."""
    rel = f"{stage}/{s.get('figure')}"
    if s.get("figure") and (run_dir / rel).exists():
        data = base64.b64encode((run_dir / rel).read_bytes()).decode("ascii")
        report.add_html(
            f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(caption)}">'
            f"<figcaption>{html.escape(caption)} ({_link(run_dir, rel, 'PNG')})</figcaption></figure>"
        )


def _track(report: Report, run_dir: Path, s: dict[str, Any]) -> None:
    """Tracked angle figure and a row per video."""
    _figure(report, run_dir, "track", s, "Float angle per frame (dots) and Kalman/RTS-smoothed (line).")
    rows = []
    for v in s.get("videos", []):
        links = _link(run_dir, f"track/{v['csv']}", "angles CSV")
        if v.get("overlay"):
            links += " · " + _link(run_dir, f"track/{v['overlay']}", "overlay video")
        rows.append(
            f"<tr><td>{html.escape(Path(v['video']).name)}</td><td>{v['frames']}</td>"
            f"<td>{100 * v['valid_share']:.1f} %</td><td>{links}</td></tr>"
        )
    report.add_html(
        "<table><tr><th>video</th><th>frames</th><th>valid</th><th>files</th></tr>" + "".join(rows) + "</table>"
    )
    for v in s.get("videos", []):  # what `track` warns of: a truncated file, repeated pictures, a float cut by the ROI
        if v.get("warnings"):
            report.add_text(f"{Path(v['video']).name}: " + " ".join(v["warnings"]))


def _identify(report: Report, run_dir: Path, s: dict[str, Any]) -> None:
    """Verdict, parameter table with 95 % intervals and per-parameter verdicts, notes on the inputs, report link."""
    report.add_text(
        f"Verdict: {s['quality']}" + (f". {' '.join(s['reasons'])}" if s["reasons"] else "."),  # each a sentence
        css_class=f"verdict-{s['quality']}",
    )
    rows = []
    for name, p in s["parameters"].items():
        label, unit = PARAMETER_LABELS.get(name, (name, ""))
        se = p.get("stderr")  # values and bounds with the digits their error allows (4 read 1.9996 as 2)
        bounds = interval_ends(p["ci95"], se, p.get("bounds")) if p.get("ci95") else [None, None]
        rows.append([label, unit, shown_with_error(p["value"], se), se, *bounds, p.get("quality", "given")])
    report.add_table(["parameter", "unit", "value", "std. error", "95 % low", "95 % high", "verdict"], rows)
    if s.get("between"):  # several signals: whether they agree when fitted alone
        report.add_text(s["between"][0].upper() + s["between"][1:] + ".")
    if s.get("input_warnings"):
        report.add_text("Inputs: " + " ".join(s["input_warnings"]))
    _links(
        report,
        run_dir,
        ("identify/params.json", "parameters (JSON)"),
        ("identify/report/index.html", "identification report"),
    )


def _plan_links(report: Report, run_dir: Path) -> None:
    """The plan's trajectory CSV and report."""
    _links(
        report,
        run_dir,
        ("plan/trajectory.csv", "nominal plan, 1 kHz robot trajectory (CSV)"),
        ("plan/report/index.html", "plan report"),
    )


def _margin_plan(report: Report, run_dir: Path, s: dict[str, Any]) -> None:
    """A move within a spill margin: transfer time against the move with no liquid, each container's wall, the risk."""
    what = "tilting move within the spill margin" if s["kind"] == "tilt_margin" else "upright move"
    _figure(report, run_dir, "plan", s, f"Wall height of each container in the independent simulation ({what}).")
    risk = s.get("risk")
    told = f"{100 * risk['p_margin_broken']:.2f} % ± {100 * risk['stderr']:.2f} %" if risk else "not estimated"
    report.add_table(
        ["transfer time T (s)", "T / no liquid", "solver status", "max tilt (deg)", "limiting container", "margins",
         "limits", "risk of breaking the margin"],
        [[s["T_s"], s["time_ratio"], s["status"], s["max_tilt_deg"], s["limiting_container"],
          "held" if s["verification_ok"] else "BROKEN", "ok" if s["limits_ok"] else "EXCEEDED", told]],
    )  # fmt: skip
    report.add_table(
        ["container", "peak wall (mm)", "allowed (mm)", "after arrival (mm)", "allowed after (mm)", "ok"],
        [[c["name"], c["peak_wall_mm"], c["allowed_wall_mm"], c["residual_wall_mm"], c["residual_max_mm"], c["ok"]]
         for c in s["containers"]],
    )  # fmt: skip
    _plan_links(report, run_dir)


def _plan(report: Report, run_dir: Path, s: dict[str, Any]) -> None:
    """Transfer time, solver, tilt, limits and the independent verification, with the files."""
    if s.get("kind") in ("upright", "tilt_margin"):
        _margin_plan(report, run_dir, s)
        return
    v = s["verification"]
    _figure(report, run_dir, "plan", s, "Container speed and tilt along the planned move.")
    report.add_table(
        [
            "transfer time T (s)",
            "segments",
            "solver status",
            "solve time (s)",
            "max tilt (deg)",
            "max tilt rate (deg/s)",
            "robot limits",
            "liquid vs container during / after (deg)",
        ],
        [
            [
                s["T_s"],
                len(s["segments"]),
                s["status"],
                s["solve_time_s"],
                s["max_tilt_deg"],
                s["max_tilt_rate_deg_s"],
                "ok" if s["limits_ok"] else "EXCEEDED",
                f"{v['peak_during_deg']:.3g} / {v['residual_deg']:.3g}",
            ]
        ],
    )
    _plan_links(report, run_dir)


def _margin_rows(s: dict[str, Any]) -> tuple[list[str], list[list[Any]]]:
    """The ranked methods of a comparison within a spill margin as a table."""
    rows = []
    for i, m in enumerate(s["ranked"], 1):
        if m["T_s"] is None:
            rows.append([i, m["label"], m["reason"], "", "", "", "", ""])
            continue
        risk = m["risk"]
        rows.append([
            i, m["label"], m["T_s"], m["acc_share"] if m["acc_share"] is not None else "", m["peak_wall_use"],
            m["residual_wall_mm"], m["meets_margin_and_residual"],
            f"{100 * risk['p_margin_broken']:.2f} ± {100 * risk['stderr']:.2f}" if risk else "n/a",
        ])  # fmt: skip
    header = ["rank", "method", "transfer time (s)", "acc share", "wall use", "after arrival (mm)",
              "meets margin and residual", "risk (%)"]  # fmt: skip
    return header, rows


def _compare(report: Report, run_dir: Path, s: dict[str, Any]) -> None:
    """The verdict sentence (coloured by the recommendation's risk) and the score table of every method, with the move
    sent under its method's row when it was slowed for the arm (`slowed_row`)."""
    rec = s.get("recommendation") or {}
    report.add_text(s["verdict"], css_class=f"verdict-{rec.get('risk', 'uncertain')}")
    if s.get("kind") == "margin":  # ranked by risk, then time
        report.add_table(*_margin_rows(s))
        _compare_links(report, run_dir, s)
        return
    slowed = slowed_row(s.get("recommended"), rec.get("checks", {}))
    rows = []
    for m in s["methods"]:
        if not m["applicable"]:
            rows.append([m["label"], "not applicable", m["reason"], "", "", ""])
            continue
        ok = "ok" if m["robot_limits_ok"] and m["move_limits_ok"] else "exceeded"
        rows.append([m["label"], m["transfer_time_s"], m["peak_during_deg"], m["residual_deg"], m["peak_tilt_deg"], ok])
        if slowed is not None and slowed.method == m["method"]:
            rows.append([slowed.label, slowed.transfer_time_s, slowed.peak_during_deg, slowed.residual_deg, None, None])
    report.add_table(
        ["method", "transfer time (s)", "peak slosh during (deg)", "residual slosh (deg)", "peak tilt (deg)", "limits"],
        rows,
    )
    _compare_links(report, run_dir, s)


def _compare_links(report: Report, run_dir: Path, s: dict[str, Any]) -> None:
    """The recommended move's CSV (when there is one), the comparison's report and its scores."""
    move = s.get("recommended")
    recommended = [(f"compare/{move['csv']}", f"recommended move: {move['label']} (CSV)")] if move else []
    _links(
        report,
        run_dir,
        *recommended,
        ("compare/report/index.html", "comparison report"),
        ("compare/scores.json", "scores (JSON)"),
    )


def _generic(report: Report, run_dir: Path, name: str, s: dict[str, Any]) -> None:
    """Scalar summary values as a table plus links to the files the stage listed."""
    scalars = [[k, v] for k, v in s.items() if isinstance(v, (int, float, str, bool)) and k not in ("report",)]
    if scalars:
        report.add_table(["figure", "value"], scalars)
    for key in ("report", "trajectory", "figure"):
        if isinstance(s.get(key), str):
            _links(report, run_dir, (f"{name}/{s[key]}", f"{name} {key}"))


RENDERERS = {"track": _track, "identify": _identify, "plan": _plan, "compare": _compare}


def overall_verdict(records: list[StageRecord]) -> tuple[str, str]:
    """(sentence, quality) over the stages: the liquid's frequency verdict, the plan's verification and limits,
    the comparison's recommendation, whether the scenario's arm can follow the move; the worst of them (a failed
    stage is unreliable; a move the arm cannot follow is at best uncertain)."""
    levels = ("good", "uncertain", "unreliable")
    parts, worst = [], "good"
    for rec in records:
        s = rec.summary or {}
        if rec.status in ("failed", "skipped"):
            parts.append(f"{rec.name} {rec.status}")
            level = "unreliable"
        elif rec.name == "identify":
            freq = s.get("parameters", {}).get("f_hz", {})
            level = freq.get("quality", s.get("quality", "good"))
            parts.append(f"liquid frequency {level} (overall {s.get('quality')})")
        elif rec.name == "plan":  # a move within a spill margin says verification_ok
            verified = s.get("verification_ok", s.get("verification", {}).get("ok", True))
            ok = s.get("limits_ok", True) and verified
            level = "good" if ok and not s.get("arm") else "uncertain"
            parts.append("plan verified within the robot limits" if ok else "plan NOT verified or over a limit")
            if s.get("arm"):
                parts.append("the robot arm cannot follow the plan")
        elif rec.name == "compare" and s.get("recommendation"):
            r = s["recommendation"]
            level = r["risk"]
            parts.append(f"recommended: {r['label']}" if r["method"] else "no method recommended")
            if (s.get("recommended") or {}).get("arm"):
                parts.append("the robot arm cannot follow the recommended move")
                level = max(level, "uncertain", key=levels.index)
        else:
            continue
        worst = max(worst, level, key=levels.index)
    return "Overall: " + ("; ".join(parts) or "no stage ran") + ".", worst


class NextStep(NamedTuple):
    """The file a user sends to the robot (relative to the run), what it is, why the scenario's arm cannot follow it
    (the stage's "arm", or None) and its joint trajectory when the arm follows it (relative to the run, or None)."""

    move: str
    what: str
    arm: dict | None
    joints: str | None


def _slowed(fit: dict | None) -> str:
    """', slowed for the arm from T s' when the stage's `arm_fit` slowed the move, else empty."""
    return f", slowed for the arm from {fit['transfer_time_first_s']:.3f} s" if fit and fit["slowed"] else ""


def _joints(run_dir: Path, stage: str, fit: dict | None) -> str | None:
    """The joints CSV the stage's `arm_fit` names, relative to the run, when it was written."""
    name = (fit or {}).get("joints_csv")
    return f"{stage}/{name}" if name and (run_dir / stage / name).exists() else None


def next_step(run_dir: Path, records: list[StageRecord]) -> NextStep | None:
    """What a user sends to the robot: the recommended move when compare recommended one, else the plan (said to be
    unchecked or not recommended); None when neither was written."""
    summaries = {r.name: r.summary or {} for r in records if r.status in ("ran", "cached")}
    move = summaries.get("compare", {}).get("recommended")
    if move and (run_dir / "compare" / move["csv"]).exists():
        fit = move.get("arm_fit")
        what = f"the recommended move: {move['label']} ({move['transfer_time_s']:.3f} s{_slowed(fit)})"
        return NextStep(f"compare/{move['csv']}", what, move.get("arm"), _joints(run_dir, "compare", fit))
    if (run_dir / "plan" / "trajectory.csv").exists():
        plan = summaries.get("plan", {})
        why = "compare recommended no method" if "compare" in summaries else "not compared with the alternatives"
        what = f"the nominal plan ({why}{_slowed(plan.get('arm_fit'))})"
        return NextStep("plan/trajectory.csv", what, plan.get("arm"), _joints(run_dir, "plan", plan.get("arm_fit")))
    return None


def _next_step(report: Report, run_dir: Path, records: list[StageRecord]) -> None:
    """The file to send to the robot, first on the page, with the nominal plan beside it when that is another."""
    step = next_step(run_dir, records)
    if step is None:
        return
    rel, what, arm, joints = step
    also = f" (or the joints, {_link(run_dir, joints, joints)})" if joints else ""
    text = f"Send to the robot: {_link(run_dir, rel, rel)}{also}, {html.escape(what)}."
    if arm is not None:
        refit = "; a plan fitted to the arm (sloshid plan's joint check, fit_joints) is slower but can" * arm["refit"]
        why = html.escape(arm["reason"] + refit)
        text = f"Do not send {_link(run_dir, rel, rel)} ({html.escape(what)}) to the robot: {why}."
    if rel != "plan/trajectory.csv" and (run_dir / "plan" / "trajectory.csv").exists():
        text += " The nominal plan is beside it: " + _link(run_dir, "plan/trajectory.csv", "plan/trajectory.csv") + "."
    report.add_html(f"<p><strong>{text}</strong></p>")


def write_index(run_dir: Path, records: list[StageRecord], title: str) -> Path:
    """Write run_dir/index.html for the stages' records; returns its path."""
    report = Report(title)
    sentence, quality = overall_verdict(records)
    report.add_text(sentence, css_class=f"verdict-{quality}")
    _next_step(report, run_dir, records)
    status = ", ".join(f"{r.name}: {r.status} ({r.seconds:.1f} s)" for r in records)
    report.add_text(f"Stages: {status}.")
    _links(report, run_dir, ("manifest.json", "manifest (resolved settings, input hashes, package version)"))
    for rec in records:
        report.add_heading(f"{rec.name} — {rec.status}")
        if rec.status in ("failed", "skipped"):
            report.add_text(rec.error, css_class="verdict-uncertain")
            continue
        render = RENDERERS.get(rec.name)
        if render is not None:
            render(report, run_dir, rec.summary)
        else:
            _generic(report, run_dir, rec.name, rec.summary)
    return report.save(run_dir)
