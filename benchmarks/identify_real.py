"""`identify` on the eight measured antisloshing runs (physical first mode 3.047 Hz): verdict, frequency and its
error, per run and jointly. Target (issue 3): at least 7 of 8 good, every good one within +-2 % of 3.047 Hz."""

from __future__ import annotations

from pathlib import Path

from bench_output import ROOT, write_results
from sloshid.identify import Identifier
from sloshid.signals import load_signal

F_PHYS = 3.047
DATA = ROOT.parent / "shared" / "data" / "antisloshing" / "slosh"


def main() -> None:
    """Identify each run and all runs jointly; write reports/benchmarks/identify_real.{json,md}."""
    sigs = [load_signal(p) for p in sorted(DATA.glob("*.mat"))]
    runs, rows = [], []
    for sig in sigs:
        res = Identifier().fit(sig).result
        f, z = res.parameters["f_hz"], res.parameters["zeta"]
        err = 100 * (f.value / F_PHYS - 1)
        runs.append({"run": Path(sig.source).stem, "quality": res.quality, "reasons": res.reasons, "f_hz": f.value,
                     "f_stderr": f.stderr, "f_err_pct": err, "zeta": z.value, "zeta_stderr": z.stderr,
                     "fit_percent": res.fit_percent(0), "window_s": [res.windows[0].t0_s, res.windows[0].t1_s]})
        rows.append([Path(sig.source).stem, res.quality, f"{f.value:.4f} ± {f.stderr:.4f}", f"{err:+.2f}",
                     f"{z.value:.4f} ± {z.stderr:.4f}", f"{res.fit_percent(0):.1f}", "; ".join(res.reasons) or "-"])
    joint = Identifier().fit(sigs).result
    jf = joint.parameters["f_hz"]
    rows.append(["joint (all 8)", joint.quality, f"{jf.value:.4f} ± {jf.stderr:.4f}", f"{100 * (jf.value / F_PHYS - 1):+.2f}",
                 f"{joint.parameters['zeta'].value:.4f} ± {joint.parameters['zeta'].stderr:.4f}", "", "; ".join(joint.reasons) or "-"])
    good = [r for r in runs if r["quality"] == "good"]
    summary = {"n_good": len(good), "n_runs": len(runs), "good_within_2pct": all(abs(r["f_err_pct"]) <= 2 for r in good),
               "all_within_2pct": all(abs(r["f_err_pct"]) <= 2 for r in runs), "joint_f_hz": jf.value}
    write_results("identify_real", {"f_phys_hz": F_PHYS, "summary": summary, "runs": runs}, "identify: eight measured antisloshing runs",
                  ["run", "verdict", "f (Hz) ± sigma", "error vs 3.047 Hz (%)", "zeta ± sigma", "fit %", "reasons"], rows,
                  f"{len(good)} of {len(runs)} good (target >= 7); every good run within ±2 %: {summary['good_within_2pct']}; "
                  f"all runs within ±2 %: {summary['all_within_2pct']}.")


if __name__ == "__main__":
    main()
