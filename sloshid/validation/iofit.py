"""Input-output identification: the nonlinear pendulum driven by each recorded move, fitted to the whole measured
record (forced response and free decay) of one or several runs at once.

Shared physics: frequency f, damping ratio zeta, the input gain k (how strongly the mode feels the pivot's
horizontal acceleration: 1 for an ideal pendulum; a real first mode carries only part of the liquid), the output
gain c (measured wall height per R tan(relative angle): the mode's wall elevation is not that of a plane, and the
sensor has its own scale; it also scales the container's own tilt, which k cannot) and the crest coefficient q (the
reading grows by q tan(relative angle): a steep wave's crest rises above the plane) and the vertical gain kv (gravity
becomes g + kv az: how strongly vertical motion pumps the mode; 1 for a pendulum). Per run: the clock lag (started
by cross-correlation, then fitted with the physics: a lag held fixed leaves phase errors that the output map would
absorb) and an offset of the measured zero. Started from the decay-only fit; bounded least squares
(scipy) on residuals scaled so that every run weighs as its NRMSE; Newey-West intervals.
"""

from __future__ import annotations

import html
import itertools
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from sloshid.core.errors import SettingError
from sloshid.core.settings import check_in_metres
from sloshid.identification.estimator import (
    Estimate,
    Identifier,
    IdentResult,
    IdentSettings,
    estimate,
    estimates_table,
)
from sloshid.identification.pt2fit import hac_covariance
from sloshid.identification.signals import Signal
from sloshid.model.pendulum import G, SloshParams, linear_tf_coeffs
from sloshid.model.pose import SMOOTH_S, Excitation, PoseLog, excitation, load_pose_log, respond
from sloshid.validation.predict import LiquidModel, plane_series, read_out
from sloshid.validation.scoring import LEAD_IN_S, align, baseline
from sloshid.validation.validate import (
    ValidationRun,
    build_report,
    measured_kind,
    measured_magnitude,
    medians,
    validate_run,
)

FIT_RATE_HZ = 50.0
"""The smoothed pivot acceleration is thinned to about this rate while fitting (the full rate scores the result)."""
FIT_RTOL = 1e-5
LAG_SPAN_S = 0.5
"""Simulated time kept beyond the aligned record's end, so that a fitted lag still finds a prediction there."""
F_SPAN = 0.3
"""The frequency is searched within +-30 % of the best start."""
GAIN_BOUNDS = (0.2, 5.0)
CREST_BOUNDS = (-1.0, 3.0)
"""The crest coefficient may come out negative (a reading flatter than the plane); 3 doubles the reading at 18 deg."""
ZETA_BOUNDS = (1e-3, 0.5)
START_ZETAS = (0.01, 0.03, 0.1)
"""Damping ratios tried as starts beside the decay-only one (real decays can be long, strongly excited moves not)."""
LAG_SCALE_S = 0.1
"""A run's lag enters the scaled vector as (lag - cross-correlation lag) / LAG_SCALE_S."""
LAG_SPAN = 1.5
"""Each lag is fitted within +-0.15 s of its cross-correlation start: under half a period of the 3 Hz mode."""
MAX_NFEV = 45
TOLERANCES = {"ftol": 1e-4, "xtol": 1e-4, "gtol": 1e-8}
"""Stop when the cost or the scaled step changes by less than 0.01 %: far below the parameters' own uncertainty."""
FITTED = ("f_hz", "zeta", "input_gain", "output_gain", "crest_coeff", "vertical_gain")
"""The shared parameters the fit moves, in the order of the scaled vector."""
N_PARAMS = len(FITTED)
SIM_CACHE = 8
"""Simulated physics kept at once (a Jacobian needs the base point and one step per physical parameter)."""
DIFF_STEP = 1e-2
"""Finite-difference step of the scaled vector (0.1 % of f, 1 % of zeta and the gains, 0.01 of q, 1 ms of a lag):
well above the integrator's noise."""


@dataclass
class _RunData:
    """One run prepared for the fit: the thinned excitation, the measured samples (measured clock), scale."""

    exc: Excitation
    t_meas: np.ndarray
    y: np.ndarray
    lag0: float
    settle_s: float
    norm: float
    kind: str


@dataclass
class IOFit:
    """Result of the input-output fit: the model, its intervals, per-run alignment and scores, the decay-only start."""

    model: LiquidModel
    parameters: dict[str, Estimate]
    decay: IdentResult
    names: list[str]
    trajectories: list[str]
    lags_s: list[float]
    offsets: list[float]
    runs: list[ValidationRun]
    """The runs scored with the fitted model (full-rate prediction, as `validate` does)."""
    decay_runs: list[ValidationRun]
    """The same runs scored with the decay-only model (input gain 1)."""
    at_bound: list[str]
    n_simulations: int

    @property
    def quality(self) -> str:
        """'good' unless a parameter ended on its bound or the median fit stays below 15 %."""
        return "uncertain" if self.reasons else "good"

    @property
    def reasons(self) -> list[str]:
        """Why the verdict is uncertain (empty when good)."""
        out = [f"{name} ended on its search bound." for name in self.at_bound]
        fit = medians(self.runs)["all"]["fit_percent"]
        if not fit >= 15.0:
            out.append(f"the median fit over the runs is only {fit:.1f} %.")
        return out

    def _verdict(self, name: str) -> dict[str, Any]:
        """A parameter's verdict and reasons, as identify's JSON gives them: 'uncertain' when it (or, for omega and l,
        f) ended on its search bound or the median fit is low, else 'good'."""
        own = {"omega_rad_s": ("f_hz",), "l_m": ("f_hz",), "d_ns_per_m": ("f_hz", "zeta")}.get(name, (name,))
        reasons = [r for r in self.reasons if not r.endswith("ended on its search bound.") or r.split(" ", 1)[0] in own]
        return {"quality": "uncertain" if reasons else "good", "reasons": reasons}

    def comparison(self) -> dict[str, Any]:
        """Median scores of the input-output model against the decay-only one on the fitted runs."""
        io, decay = medians(self.runs), medians(self.decay_runs)
        return {
            "input_output": io,
            "decay_only": decay,
            "fit_gain_points": io["all"]["fit_percent"] - decay["all"]["fit_percent"],
            "abs_peak_error_change_points": io["during"]["abs_peak_error_percent"]
            - decay["during"]["abs_peak_error_percent"],
        }

    def report(self, directory: str | Path, links: dict[str, str] | None = None) -> Path:
        """Write the HTML report (the fitted parameters and the runs as `validate` shows them) to
        directory/index.html; `links` (text -> relative href) are shown at the top."""
        rep = build_report(self.runs, self.model, "sloshid identify (input-output)")
        rep.items.insert(0, f"<pre>{html.escape(self.summary())}</pre>")
        rep.add_links(links or {})
        return rep.save(directory)

    def plot(self, ax=None):
        """The first run measured and predicted by the fitted model (as `validate` draws it); returns the figure."""
        axes = self.runs[0].plot(None if ax is None else [ax, ax.twinx()])
        return axes[0].figure

    def to_pandas(self):
        """The fitted parameters as a table: one row each with value, standard error and 95 % interval."""
        return estimates_table(self.parameters)

    def to_dict(self) -> dict[str, Any]:
        """The `identify` JSON schema (the decay-only fit's keys) with the input-output parameters and extras."""
        base = self.decay.to_dict()
        inputs = {w for sig in self.decay.signals for w in sig.warnings}
        num, den = linear_tf_coeffs(self.model.params)
        params = {k: {**v.to_dict(), **self._verdict(k)} for k, v in self.parameters.items()}
        if self.decay.mass_kg is not None:
            params["m_kg"] = {"value": self.decay.mass_kg}
        per_signal = []
        for i, run in enumerate(self.runs):
            per_signal.append(
                {
                    "source": self.decay.signals[i].source,
                    "trajectory": self.trajectories[i],
                    "fitted_lag_s": self.lags_s[i],
                    "fitted_offset": self.offsets[i],
                    **run.to_dict(),
                }
            )
        return {
            **base,
            "method": "input-output",
            "quality": self.quality,
            "reasons": self.reasons,
            # the decay-only start's remarks on its own estimates are marked; those on the inputs stay as they are
            "notes": [
                n if n in inputs or n.startswith("the mass ") else f"decay-only start: {n}" for n in base["notes"]
            ]
            + ([] if "vertical_gain" in self.parameters else [HELD_VERTICAL]),
            "parameters": params,
            "decay_only_parameters": base["parameters"],
            "transfer_function": {**base["transfer_function"], "num": [self.model.input_gain * num[0]], "den": den},
            "geometry": {
                "container_radius_m": self.model.radius_m,
                "axis_offset_m": self.model.axis_offset_m,
                "smooth_s": self.model.smooth_s,
            },
            "fit": {
                "model": "nonlinear pendulums (seed eq. 2 per axis, world frame) driven by input_gain x the pivot's "
                "horizontal acceleration, g + vertical_gain x az; output output_gain x R tan(angle to the container axis) (or x that "
                "angle) x (1 + crest_coeff x tan(that angle)); per run lag and offset",
                "fit_percent": medians(self.runs)["all"]["fit_percent"],
                "n_simulations": self.n_simulations,
                "interval_method": "Newey-West sandwich on the least-squares Jacobian (per-run blocks); normal 95 %",
                "per_signal": per_signal,
            },
            "comparison_with_decay_only": self.comparison(),
        }

    def summary(self) -> str:
        """Readable summary: parameters, per-run scores, and the gain over the decay-only model."""
        lines = [f"sloshid identify (input-output): {len(self.runs)} run(s)"]
        for key, est in self.parameters.items():
            lines.append(
                f"  {key:<13} = {est.shown()} ± {est.stderr:.2g}  (95 % CI {est.shown(est.ci95[0])} .. "
                f"{est.shown(est.ci95[1])})"
            )
        if "vertical_gain" not in self.parameters:
            lines.append(f"  {HELD_VERTICAL}")
        d = self.decay.parameters
        lines.append(f"  decay-only start: f = {d['f_hz'].value:.4g} Hz, zeta = {d['zeta'].value:.3g}")
        for name, run, lag, dec in zip(self.names, self.runs, self.lags_s, self.decay_runs):
            lines.append(
                f"  {name}: fitted lag {lag:.3f} s, fit {run.scores['all'].fit_percent:.1f} % (decay-only "
                f"{dec.scores['all'].fit_percent:.1f} %), peak error {run.scores['during'].peak_error_percent:+.1f} % "
                f"(decay-only {dec.scores['during'].peak_error_percent:+.1f} %)"
            )
        c = self.comparison()
        lines.append(
            f"  median fit {c['input_output']['all']['fit_percent']:.1f} % vs decay-only "
            f"{c['decay_only']['all']['fit_percent']:.1f} %; median |peak error| "
            f"{c['input_output']['during']['abs_peak_error_percent']:.1f} % vs "
            f"{c['decay_only']['during']['abs_peak_error_percent']:.1f} % (on the fitted runs)"
        )
        lines.append(f"verdict: {self.quality}")
        lines += [f"  - {r}" for r in self.reasons]
        return "\n".join(lines)


def _thin(exc: Excitation, rate_hz: float) -> Excitation:
    """Every k-th sample of an already smoothed excitation (k so that the rate stays at or above rate_hz)."""
    step = max(1, math.floor((1.0 / (exc.t_s[1] - exc.t_s[0])) / rate_hz))
    return replace(exc, t_s=exc.t_s[::step], acc_m_s2=exc.acc_m_s2[::step], rot=exc.rot[::step])


VERTICAL_SHARE = 0.01
"""The vertical gain is fitted only when some run's vertical pivot acceleration (RMS) reaches this share of g, against
which it acts (g + kv az): a move without vertical motion gave it no information, and it was reported as 1.2456 +- 0,
rated good. The shared 3-D runs lift the container by far more."""


HELD_VERTICAL = (
    f"vertical_gain held at 1 (a pendulum's): no run moves the container vertically (its vertical acceleration stays "
    f"below {100 * VERTICAL_SHARE:g} % of g, RMS), so the data say nothing of it."
)


def _vertical_share(exc: Excitation) -> float:
    """RMS of the pivot's vertical acceleration over g."""
    return float(np.sqrt(np.mean(exc.acc_m_s2[:, 2] ** 2))) / G


def _prepare(pose: PoseLog, sig: Signal, start: LiquidModel) -> _RunData:
    """Thin the excitation, align the start model's prediction with the measurement, subtract the baseline; later
    simulations run only as long as the aligned record needs (plus the lag's search span)."""
    kind = measured_kind(sig, start)
    exc = _thin(excitation(pose, start.axis_offset_m, start.smooth_s), FIT_RATE_HZ)
    y_all = measured_magnitude(sig, kind)
    resp = respond(
        exc, start.params, start.input_gain, float(sig.t_s[-1] - sig.t_s[0]) + 1.0, FIT_RTOL, FIT_RTOL * 1e-3
    )
    al = align(sig.t_s, y_all, resp.t_s, start.reading(resp, kind), exc.move_span_s)
    keep = sig.t_s - al.lag_s >= exc.move_span_s[0] - LEAD_IN_S
    y = y_all[keep] - baseline(sig.t_s, y_all, exc.move_span_s[0] + al.lag_s)
    settle = max(float(sig.t_s[-1] - al.lag_s - exc.t_s[-1]) + LAG_SPAN_S, 0.1)
    norm = float(np.linalg.norm(y - y.mean())) or 1.0
    return _RunData(exc, sig.t_s[keep], y, al.lag_s, settle, norm, kind)


class _Problem:
    """Residuals of x = [10 (f/f0 - 1), log(zeta/zeta0), log k, log c, q, log kv, (lag_i - lag0_i) / LAG_SCALE_S ...]: the
    shared physics and each run's lag; each run's offset is its mean residual (variable projection), and each run
    weighs as its NRMSE."""

    def __init__(self, data: list[_RunData], f0: float, zeta0: float, radius_m: float | None):
        self.data, self.f0, self.zeta0, self.radius_m = data, f0, zeta0, radius_m
        self.vertical = any(_vertical_share(d.exc) >= VERTICAL_SHARE for d in data)
        self.lags = [d.lag0 for d in data]
        self.n_sim = 0
        self._sims: dict[tuple[float, float, float, float], list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}

    def physical(self, x: np.ndarray) -> tuple[float, float, float, float, float, float]:
        """(f, zeta, k, c, q, kv) from the scaled vector."""
        f, zeta = self.f0 * (1 + x[0] / 10), self.zeta0 * math.exp(x[1])
        return f, zeta, math.exp(x[2]), math.exp(x[3]), float(x[4]), math.exp(x[5])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the scaled vector (f within F_SPAN of the start, the others their *_BOUNDS)."""
        n = len(self.data)
        gain_lo, gain_hi = math.log(GAIN_BOUNDS[0]), math.log(GAIN_BOUNDS[1])
        lo = [-10 * F_SPAN, math.log(ZETA_BOUNDS[0] / self.zeta0), gain_lo, gain_lo, CREST_BOUNDS[0], gain_lo]
        hi = [10 * F_SPAN, math.log(ZETA_BOUNDS[1] / self.zeta0), gain_hi, gain_hi, CREST_BOUNDS[1], gain_hi]
        if not self.vertical:  # nothing to fit the vertical gain on: held at 1 (a pendulum's)
            lo[5], hi[5] = -1e-12, 1e-12
        return np.array(lo + [-LAG_SPAN] * n), np.array(hi + [LAG_SPAN] * n)

    def lags_at(self, x: np.ndarray) -> list[float]:
        """Each run's lag (s) at x (the starts when x holds the physics alone)."""
        shifts = x[N_PARAMS:] if x.size > N_PARAMS else np.zeros(len(self.lags))
        return [lag + LAG_SCALE_S * float(v) for lag, v in zip(self.lags, shifts)]

    def predictions(self, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Predicted (t, series) of every run (trajectory clock); recent physics' simulations are kept, so that a
        step of the output map alone (gain, crest) simulates nothing."""
        f, zeta, k, c, q, kv = self.physical(x)
        if (f, zeta, k, kv) not in self._sims:
            params = SloshParams.from_modal(2 * math.pi * f, zeta)
            self.n_sim += 1
            if len(self._sims) >= SIM_CACHE:
                self._sims.clear()
            sims = []
            for d in self.data:
                resp = respond(d.exc, params, k, d.settle_s, FIT_RTOL, FIT_RTOL * 1e-3, kv)
                sims.append((resp.t_s, *plane_series(resp, d.kind, self.radius_m)))
            self._sims[f, zeta, k, kv] = sims
        return [(t, read_out(plane, slope, c, q)) for t, plane, slope in self._sims[f, zeta, k, kv]]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Stacked (y - yhat - offset) / |y - mean y| of all runs."""
        parts = []
        for d, (tp, yp), lag in zip(self.data, self.predictions(x), self.lags_at(x)):
            r = d.y - np.interp(d.t_meas - lag, tp, yp, left=yp[0])
            parts.append((r - r.mean()) / d.norm)
        return np.concatenate(parts)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Forward differences with fixed steps (scipy's relative steps vanish at x = 0, below integrator noise)."""
        r0 = self.residuals(x)
        cols = []
        for j in range(x.size):
            step = np.zeros_like(x)
            step[j] = DIFF_STEP
            cols.append((self.residuals(x + step) - r0) / DIFF_STEP)
        return np.column_stack(cols)

    def realign(self, x: np.ndarray) -> None:
        """Per-run lags from the cross-correlation of the current model's prediction over the move."""
        for i, (d, (tp, yp)) in enumerate(zip(self.data, self.predictions(x))):
            self.lags[i] = align(d.t_meas, d.y, tp, yp, d.exc.move_span_s).lag_s

    def offsets(self, x: np.ndarray) -> list[float]:
        """The projected offsets at x (measured unit)."""
        return [
            float(np.mean(d.y - np.interp(d.t_meas - lag, tp, yp, left=yp[0])))
            for d, (tp, yp), lag in zip(self.data, self.predictions(x), self.lags_at(x))
        ]


def _best_start(prob: _Problem, candidates_hz: list[float]) -> None:
    """Move the problem's reference (f0, zeta0) to the lowest-cost start among the candidate frequencies (the
    decay-only one and its half: a measured magnitude of a planar slosh repeats at twice the mode's frequency) and
    a few damping ratios."""
    best = (math.inf, prob.f0, prob.zeta0)
    zero, zetas = np.zeros(N_PARAMS), sorted({prob.zeta0, *START_ZETAS})
    for f in candidates_hz:
        for z in zetas:
            prob.f0, prob.zeta0 = f, z
            best = min(best, (float(np.sum(prob.residuals(zero) ** 2)), f, z))
    prob.f0, prob.zeta0 = best[1], best[2]


def fit_io(
    poses: list[PoseLog],
    signals: list[Signal],
    radius_m: float | None,
    axis_offset_m: float = 0.0,
    smooth_s: float = SMOOTH_S,
    settings: IdentSettings | None = None,
    names: list[str] | None = None,
) -> IOFit:
    """Fit f, zeta, the input, output and vertical gains and the crest coefficient jointly over the runs (own lag and
    offset each), from the decay-only start."""
    if len(poses) != len(signals):
        raise SettingError(
            "trajectory",
            f"give one {{name}} per signal, in the same order: {len(signals)} signal(s), {len(poses)} trajectories.",
        )
    settings = settings or IdentSettings()
    decay = Identifier(settings).fit(signals).result  # the start, and the model the result is compared with
    f0 = decay.parameters["f_hz"].value
    zeta0 = min(max(decay.parameters["zeta"].value, ZETA_BOUNDS[0]), ZETA_BOUNDS[1])
    start = LiquidModel(SloshParams.from_modal(2 * math.pi * f0, zeta0), 1.0, radius_m, axis_offset_m, smooth_s)
    prob = _Problem([_prepare(p, s, start) for p, s in zip(poses, signals)], f0, zeta0, radius_m)
    _best_start(prob, [f0, f0 / 2])
    prob.realign(np.zeros(N_PARAMS))
    lo, hi = prob.bounds()
    x = np.zeros(lo.size)
    sol = least_squares(
        prob.residuals, x, bounds=(lo, hi), jac=prob.jacobian, x_scale="jac", max_nfev=MAX_NFEV, **TOLERANCES
    )
    f, zeta, k, c, q, kv = physical = prob.physical(sol.x)
    held = () if prob.vertical else ("vertical_gain",)
    at_bound = [nm for nm, v, a, b in zip(FITTED, sol.x, lo, hi) if min(v - a, b - v) < 1e-6 and nm not in held]
    params = {k: v for k, v in _estimates(sol, prob, physical, settings.mass_kg).items() if k not in held}
    mass = settings.mass_kg or 1.0
    physics = SloshParams.from_modal(2 * math.pi * f, zeta, mass)
    model = LiquidModel(physics, k, radius_m, axis_offset_m, smooth_s, c, q, kv)
    names = names or [s.source for s in signals]
    runs = [validate_run(p, s, model, nm) for p, s, nm in zip(poses, signals, names)]
    decay_model = replace(start, params=decay.params)
    decay_runs = [validate_run(p, s, decay_model, nm) for p, s, nm in zip(poses, signals, names)]
    return IOFit(
        model,
        params,
        decay,
        names,
        [p.source for p in poses],
        prob.lags_at(sol.x),
        prob.offsets(sol.x),
        runs,
        decay_runs,
        at_bound,
        prob.n_sim,
    )


def fit_io_files(
    trajectories: list[str],
    signals: list[Signal],
    settings: IdentSettings,
    radius_m: float | None,
    axis_offset_m: float,
    smooth_s: float,
    pose_columns: str | None = None,
) -> IOFit:
    """`identify --trajectory`: check the counts and geometry, read the pose logs, fit."""
    if len(trajectories) != len(signals):
        raise SettingError(
            "trajectory",
            f"give one {{name}} per signal, in the same order: {len(signals)} signal(s), "
            f"{len(trajectories)} trajectories.",
        )
    check_in_metres("container_radius_m", radius_m)
    if radius_m is None and any(s.unit == "mm" for s in signals):
        raise SettingError("container_radius_m", "wall heights in mm need the container radius: give {name} (m).")
    poses = [load_pose_log(t, pose_columns) for t in trajectories]
    return fit_io(poses, signals, radius_m, axis_offset_m, smooth_s, settings, [Path(s.source).stem for s in signals])


def _estimates(
    sol, prob: _Problem, physical: tuple[float, float, float, float, float, float], mass: float | None
) -> dict[str, Estimate]:
    """Parameters (f, zeta, k, c, q, kv) with Newey-West standard errors (per-run blocks), mapped from the scaled
    vector."""
    f, zeta, k, c, q, kv = physical
    data = prob.data
    sizes = np.cumsum([0] + [d.y.size for d in data])
    blocks = [slice(a, b) for a, b in itertools.pairwise(sizes)]
    periods = [max(round(1.0 / (f * np.median(np.diff(d.t_meas)))), 1) for d in data]
    # a held vertical gain is no parameter: its column would count as one more direction for the others to trade
    # against (a review: f's standard error 1.69 times too wide)
    held = 5 if not prob.vertical else None
    jac = sol.jac if held is None else np.delete(sol.jac, held, axis=1)
    cov, _naive, _lags = hac_covariance(jac, sol.fun, blocks, periods)
    variances = np.diag(cov) if held is None else np.insert(np.diag(cov), held, 0.0)
    d_scaled = np.array([prob.f0 / 10, zeta, k, c, 1.0, kv])
    se = np.sqrt(np.clip(variances[:N_PARAMS], 0, None)) * d_scaled
    omega, se_w = 2 * math.pi * f, 2 * math.pi * se[0]
    out = {
        "f_hz": estimate(f, se[0]),
        "omega_rad_s": estimate(omega, se_w),
        "zeta": estimate(zeta, se[1], floor=0.0),
        "l_m": estimate(G / omega**2, 2 * G / omega**3 * se_w),
        "input_gain": estimate(k, se[2], floor=0.0),
        "output_gain": estimate(c, se[3], floor=0.0),
        "crest_coeff": estimate(q, se[4]),
        "vertical_gain": estimate(kv, se[5], floor=0.0),
    }
    if mass is not None:
        out["d_ns_per_m"] = estimate(
            2 * mass * omega * zeta, 2 * mass * math.hypot(zeta * se_w, omega * se[1]), floor=0.0
        )
    return out
