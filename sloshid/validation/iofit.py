"""Input-output identification: the physics-first liquid model driven by each recorded move, fitted to the whole
measured record (forced response and free decay) of one or several runs at once.

Physics fixes the structure (`predict.LiquidModel`: one spherical pendulum in the world frame, pivoted at the surface,
under gravity g + az, a turn about a horizontal axis felt where linear potential theory puts it when the fill height is
known; the wall reads the static surface plus the first mode's wave). The fit sets what physics leaves
open, each parameter pulled toward its physical prior and bounded by its physical range (`PRIORS`): the frequency f
(prior: the cylinder's first mode from the geometry), the damping ratio zeta (prior 0.01), the breaking drag (prior
1 per rad: damping that grows with the wave's speed, which bounds parametric resonance), the wall's wave share c
(prior 2 / (xi^2 - 1) = 0.84), the crest coefficient q (prior 0.58, a second-order standing wave) and the tilt of
the wall reading's level at rest along the container's two axes (prior 0: a container mounted off the logged axis, or
a camera's level off; the reading's zero is its own reading at rest, as the measured zero is the quiet lead-in) and
the half-width of the arc of wall each camera's edge-on points stand for (prior 22.5 deg, between the four points
alone and the whole wall). Per run: the clock lag (started by cross-correlation, then fitted with the physics) and an
offset of the measured zero.
Bounded least squares (scipy) on residuals scaled so that every run weighs as its NRMSE, plus one row per prior;
Newey-West intervals.
"""

from __future__ import annotations

import html
import itertools
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
from scipy.optimize import least_squares

from sloshid.core.errors import SettingError
from sloshid.core.settings import check_axis_offset, check_in_metres, setting_field
from sloshid.identification.estimates import Estimate, estimate
from sloshid.identification.estimator import Identifier, IdentResult, IdentSettings, estimates_table
from sloshid.identification.pt2fit import hac_covariance
from sloshid.identification.signals import Signal
from sloshid.model.pendulum import XI_CYLINDER, G, SloshParams, cylinder_first_mode_omega, linear_tf_coeffs
from sloshid.model.pose import (
    MOTION_QUANTITIES,
    SMOOTH_S,
    Excitation,
    PoseLog,
    excitation,
    load_pose_log,
    motion_range,
    respond,
)
from sloshid.validation.predict import FITTED_ERRORS, STRUCTURE, LiquidModel, read_out, rest_gradient, wall_parts
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
PRIORS = {
    "f_hz": (None, 0.03, (0.85, 1.15)),
    "zeta": (0.01, math.log(3.0), (0.002, 0.15)),
    "drag": (1.0, 1.0, (0.5, 10.0)),
    "wave_share": (2 / (XI_CYLINDER**2 - 1), 0.05, (0.3, 1.2)),
    "crest_coeff": (0.58, 0.5, (-0.5, 1.5)),
    "rest_tilt_x_deg": (0.0, 2.0, (-6.0, 6.0)),
    "rest_tilt_y_deg": (0.0, 2.0, (-6.0, 6.0)),
    "view_arc_deg": (22.5, 15.0, (0.0, 45.0)),
}
"""Per fitted parameter: (prior, its standard deviation, physical range). f: the geometry's first mode (else the
decay-only fit's), 3 % (fill height and meniscus), range +-15 % of the prior; zeta: 0.01 (the wall's boundary layer
and contact line of a small water tank), a factor of 3 (log scale); the breaking drag: 1 per rad (an equivalent
damping ratio 0.4 x drag x the angle: 0.1 at 15 deg), at least 0.5 (every liquid breaks: vertical pumping at twice
the mode's frequency and 1 g turns the pendulum to 66 deg with 0.5, past 90 deg with 0.3, a flip no liquid makes);
the wave share: linear theory's first-mode wall share, exact for an upright cylinder at any depth, sd 0.05 (the
meniscus and second-order terms; a sensor's scale would scale the static surface as much and is no part of it), range
0.3-1.2; the crest: a Stokes standing wave's k a / 2 over the centre slope 1.58 a / R, k = 1.84 / R; the rest tilts:
0 (an upright container whose reading shares the liquid's level), 2 deg (a container seated a few tenths of a
millimetre off square over its radius, or a camera's roll), at most 6 deg (R tan 6 deg = 5 mm at the wall: more is no
mounting error); the view's arc: a level camera's highest outline point is the whole wall's (45 deg), one looking
along the surface from a little above or below sees the wall edge-on only near its silhouette (0), so 22.5 deg, sd
15, within 0-45."""


def prior_weight(cost: float, periods: float) -> float:
    """Weight of the prior rows: the runs' residual scale per period of the mode, sqrt(cost / periods), so that a prior
    counts like one period of data (maximum a posteriori with the residuals' own scale and one independent sample per
    period, the residuals being correlated over a period): a parameter the records pin moves freely, one they leave
    open (a kind of motion they lack) stays with its physics."""
    return math.sqrt(max(cost, 1e-12) / max(periods, 1.0))


START_ZETAS = (0.01, 0.02, 0.04)
"""Damping ratios tried as starts (real decays can be long, strongly excited moves not)."""
LAG_SCALE_S = 0.1
"""A run's lag enters the scaled vector as (lag - cross-correlation lag) / LAG_SCALE_S."""
LAG_SPAN = 1.5
"""Each lag is fitted within +-0.15 s of its cross-correlation start: under half a period of the 3 Hz mode."""
MAX_NFEV = 30
TOLERANCES = {"ftol": 1e-4, "xtol": 1e-4, "gtol": 1e-8}
"""Stop when the cost or the scaled step changes by less than 0.01 %: far below the parameters' own uncertainty."""
FITTED = tuple(PRIORS)
"""The shared parameters the fit moves, in the order of the scaled vector."""
N_PARAMS = len(FITTED)
SIM_CACHE = 6
"""Simulated physics kept at once (a Jacobian needs the base point and one step per simulated parameter)."""
DIFF_STEP = 1e-2
"""Finite-difference step of the scaled vector (0.1 % of f, 1 % of zeta, 0.01 of c and q, 0.01 deg of a rest tilt,
0.01 deg of the view's arc, 1 ms of a lag): well above the integrator's noise."""


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


@dataclass(kw_only=True)
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
    """The same runs scored with the decay-only model (its f and zeta, the wall reading the pendulum's plane)."""
    at_bound: list[str]
    n_simulations: int
    priors: dict[str, float]
    """Each fitted parameter's physical prior."""
    ranges: dict[str, tuple[float, float]]
    """Each fitted parameter's physical range (the fit's bounds)."""

    @property
    def quality(self) -> str:
        """'good' unless a parameter ended on its bound or the median fit stays below 15 %."""
        return "uncertain" if self.reasons else "good"

    @property
    def reasons(self) -> list[str]:
        """Why the verdict is uncertain (empty when good)."""
        out = [
            f"{name} ended at the edge of its physical range {PRIORS[name][2][0]:g}-{PRIORS[name][2][1]:g}"
            + (" (times the prior)" if name == "f_hz" else "")
            + ": the runs ask for a liquid this model does not describe."
            for name in self.at_bound
        ]
        fit = medians(self.runs)["all"]["fit_percent"]
        if not fit >= 15.0:
            out.append(f"the median fit over the runs is only {fit:.1f} %.")
        return out

    def _verdict(self, name: str) -> dict[str, Any]:
        """A parameter's verdict and reasons, as identify's JSON gives them: 'uncertain' when it (or, for omega and l,
        f) ended on its search bound or the median fit is low, else 'good'."""
        own = {"omega_rad_s": ("f_hz",), "l_m": ("f_hz",), "d_ns_per_m": ("f_hz", "zeta")}.get(name, (name,))
        reasons = [r for r in self.reasons if " its physical range " not in r or r.split(" ", 1)[0] in own]
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
            ],
            "parameters": params,
            "decay_only_parameters": base["parameters"],
            "transfer_function": {**base["transfer_function"], "num": num, "den": den},
            "geometry": {
                "container_radius_m": self.model.radius_m,
                "axis_offset_m": self.model.axis_offset_m,
                "smooth_s": self.model.smooth_s,
                "views_deg": self.model.views_deg,
                "fill_height_m": self.model.fill_height_m,
            },
            "fit": {
                "structure": STRUCTURE,
                "model": "one spherical pendulum (world frame, pivot at the surface; with the fill height a turn about a "
                "horizontal axis is felt where linear potential theory puts it) under the pivot's acceleration, "
                "gravity g + az, damped by zeta and the breaking drag; wall = R |static slope + wave_share x wave slope + rest slope| (1 + crest_coeff x its wave part), "
                "less its reading at rest (rest slope: tan rest_tilt_x_deg, tan rest_tilt_y_deg), read on the wall within "
                "view_arc_deg of the views' edge-on points; per run lag and offset",
                "priors": {
                    k: {"value": v, "sd": PRIORS[k][1], "range": list(self.ranges[k])} for k, v in self.priors.items()
                },
                "motion_range": dict(self.model.envelope),
                "model_error_log_sd": self.model.model_error,
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
            lines.append(f"  {key:<15} = {est.shown()} ± {est.stderr:.2g}  (95 % CI {est.interval()})")
        lines.append(
            "  priors: "
            + ", ".join(
                f"{k} {v:.3g} (range {self.ranges[k][0]:.3g}-{self.ranges[k][1]:.3g})" for k, v in self.priors.items()
            )
        )
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
    axis_acc = None if exc.axis_acc_m_s2 is None else exc.axis_acc_m_s2[::step]
    return replace(exc, t_s=exc.t_s[::step], acc_m_s2=exc.acc_m_s2[::step], rot=exc.rot[::step], axis_acc_m_s2=axis_acc)


def _prepare(pose: PoseLog, sig: Signal, start: LiquidModel) -> _RunData:
    """Thin the excitation, align the start model's prediction with the measurement, subtract the baseline; later
    simulations run only as long as the aligned record needs (plus the lag's search span)."""
    kind = measured_kind(sig, start)
    exc = _thin(excitation(pose, start.axis_offset_m, start.smooth_s), FIT_RATE_HZ)
    y_all = measured_magnitude(sig, kind)
    resp = respond(
        exc,
        start.params,
        settle_s=float(sig.t_s[-1] - sig.t_s[0]) + 1.0,
        rtol=FIT_RTOL,
        atol=FIT_RTOL * 1e-3,
        spherical=True,
        depths_m=start.depths_m,
    )
    al = align(sig.t_s, y_all, resp.t_s, start.reading(resp, kind), exc.move_span_s, sig.source)
    keep = sig.t_s - al.lag_s >= exc.move_span_s[0] - LEAD_IN_S
    y = y_all[keep] - baseline(sig.t_s, y_all, exc.move_span_s[0] + al.lag_s)
    settle = max(float(sig.t_s[-1] - al.lag_s - exc.t_s[-1]) + LAG_SPAN_S, 0.1)
    norm = float(np.linalg.norm(y - y.mean())) or 1.0
    return _RunData(exc, sig.t_s[keep], y, al.lag_s, settle, norm, kind)


class _Problem:
    """Residuals of x = [10 (f/f_p - 1), log(zeta/zeta_p), b - b_p, c - c_p, q - q_p, the rest tilts and the
    view's arc (deg), (lag_i - lag0_i) / LAG_SCALE_S ...] (p: the priors): each run's, weighing as its NRMSE, with its
    offset the mean residual (variable projection), then one row per prior, `weight` x (distance from it) / its
    standard deviation (`prior_weight`)."""

    def __init__(
        self,
        data: list[_RunData],
        priors: dict[str, float],
        radius_m: float | None,
        views: float | None,
        depths_m: tuple[float, float] = (0.0, 0.0),
    ):
        self.data, self.priors, self.radius_m, self.views, self.depths_m = data, priors, radius_m, views, depths_m
        self.lags = [d.lag0 for d in data]
        self.weight = 1.0
        """Weight of the prior rows (`prior_weight`), set once at the start so that the cost stays one function."""
        self.n_sim = 0
        self._sims: dict[tuple[float, float, float], list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}

    def physical(self, x: np.ndarray) -> dict[str, float]:
        """Each fitted parameter's value (FITTED order) from the scaled vector."""
        p = self.priors
        out = {"f_hz": p["f_hz"] * (1 + x[0] / 10), "zeta": p["zeta"] * math.exp(x[1])}
        return out | {k: p[k] + v for k, v in zip(FITTED[2:], x[2:N_PARAMS])}

    def scaled(self, f: float, zeta: float) -> np.ndarray:
        """The scaled vector of the physics (f, zeta) with the others at their priors."""
        start = [10 * (f / self.priors["f_hz"] - 1), math.log(zeta / self.priors["zeta"])]
        return np.array(start + [0.0] * (N_PARAMS - 2))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the scaled vector: the physical ranges and the lags' spans."""
        n, (f_lo, f_hi), (z_lo, z_hi) = len(self.data), PRIORS["f_hz"][2], PRIORS["zeta"][2]
        p = self.priors
        lo = [10 * (f_lo - 1), math.log(z_lo / p["zeta"]), *(PRIORS[k][2][0] - p[k] for k in FITTED[2:])]
        hi = [10 * (f_hi - 1), math.log(z_hi / p["zeta"]), *(PRIORS[k][2][1] - p[k] for k in FITTED[2:])]
        return np.array(lo + [-LAG_SPAN] * n), np.array(hi + [LAG_SPAN] * n)

    def prior_rows(self, x: np.ndarray) -> np.ndarray:
        """`weight` x each parameter's distance from its prior over the prior's standard deviation."""
        sds = np.array([10 * PRIORS["f_hz"][1], *(PRIORS[k][1] for k in FITTED[1:])])
        return self.weight * x[:N_PARAMS] / sds

    def lags_at(self, x: np.ndarray) -> list[float]:
        """Each run's lag (s) at x (the starts when x holds the physics alone)."""
        shifts = x[N_PARAMS:] if x.size > N_PARAMS else np.zeros(len(self.lags))
        return [lag + LAG_SCALE_S * float(v) for lag, v in zip(self.lags, shifts)]

    def predictions(self, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Predicted (t, series) of every run (trajectory clock); recent physics' simulations are kept, so that a
        step of the wall's reading alone (`predict.READING`) simulates nothing."""
        v = self.physical(x)
        f, zeta, b = v["f_hz"], v["zeta"], v["drag"]
        c, q = v["wave_share"], v["crest_coeff"]
        rest = rest_gradient(v["rest_tilt_x_deg"], v["rest_tilt_y_deg"])
        if (f, zeta, b) not in self._sims:
            params = SloshParams.from_modal(2 * math.pi * f, zeta)
            self.n_sim += 1
            if len(self._sims) >= SIM_CACHE:
                self._sims.clear()
            sims = []
            for d in self.data:
                resp = respond(
                    d.exc,
                    params,
                    settle_s=d.settle_s,
                    rtol=FIT_RTOL,
                    atol=FIT_RTOL * 1e-3,
                    spherical=True,
                    drag=b,
                    depths_m=self.depths_m,
                )
                sims.append((resp.t_s, *wall_parts(resp)))
            self._sims[f, zeta, b] = sims
        return [
            (t, read_out(static, wave, c, q, d.kind, self.radius_m, self.views, rest, v["view_arc_deg"]))
            for d, (t, static, wave) in zip(self.data, self._sims[f, zeta, b])
        ]

    def run_residuals(self, x: np.ndarray) -> np.ndarray:
        """Stacked (y - yhat - offset) / |y - mean y| of all runs."""
        parts = []
        for d, (tp, yp), lag in zip(self.data, self.predictions(x), self.lags_at(x)):
            r = d.y - np.interp(d.t_meas - lag, tp, yp, left=yp[0])
            parts.append((r - r.mean()) / d.norm)
        return np.concatenate(parts)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """The runs' residuals and the prior rows."""
        return np.concatenate([self.run_residuals(x), self.prior_rows(x)])

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


def _best_start(prob: _Problem, candidates_hz: list[float]) -> np.ndarray:
    """The start whose runs' residuals are the smallest among the candidate frequencies (the prior and the decay-only
    fit's) and a few damping ratios, the others at their priors."""
    starts = [prob.scaled(f, z) for f in candidates_hz for z in START_ZETAS]
    return min(starts, key=lambda x: float(np.sum(prob.run_residuals(x) ** 2)))


def fit_io(
    poses: list[PoseLog],
    signals: list[Signal],
    radius_m: float | None,
    axis_offset_m: float = 0.0,
    smooth_s: float = SMOOTH_S,
    settings: IdentSettings | None = None,
    names: list[str] | None = None,
    views_deg: float | None = None,
) -> IOFit:
    """Fit f, zeta, the drag, the wall's wave share, crest coefficient and rest tilts (and, with `views_deg`, the
    views' arc) jointly over the runs (own lag and offset each), each toward its physical prior and within its physical
    range; `views_deg`: the wall is read in two views 90 deg apart (`predict.read_out`)."""
    if len(poses) != len(signals):
        raise SettingError(
            "trajectory",
            f"give one {{name}} per signal, in the same order: {len(signals)} signal(s), {len(poses)} trajectories.",
        )
    settings = settings or IdentSettings()
    decay = Identifier(settings).fit(signals).result  # a start, and the model the result is compared with
    f_decay = decay.parameters["f_hz"].value
    radius, fill = settings.container_radius_m, settings.fill_height_m
    geometric = radius is not None and fill is not None
    f_prior = (
        cylinder_first_mode_omega(radius, fill) / (2 * math.pi) if radius is not None and fill is not None else f_decay
    )
    # only f's prior (None in PRIORS) comes from the data; the others are numbers
    priors = {"f_hz": f_prior, **{k: cast(float, PRIORS[k][0]) for k in FITTED[1:]}}
    ranges = {
        k: (priors[k] * lo, priors[k] * hi) if k == "f_hz" else (lo, hi) for k, (_, _, (lo, hi)) in PRIORS.items()
    }
    start = LiquidModel(
        SloshParams.from_modal(2 * math.pi * f_prior, priors["zeta"]),
        radius_m,
        axis_offset_m,
        smooth_s,
        wave_share=priors["wave_share"],
        drag=priors["drag"],
        crest_coeff=priors["crest_coeff"],
        views_deg=views_deg,
        fill_height_m=fill if radius_m is not None else None,
    )
    prob = _Problem(
        [_prepare(p, s, start) for p, s in zip(poses, signals)], priors, radius_m, views_deg, start.depths_m
    )
    # a magnitude's decay rings at twice the mode's frequency: the free-decay fit's half is a candidate too, and
    # without the geometry the better of the two is the prior
    halves = [f_decay, f_decay / 2]
    if not geometric:
        # the runs' residuals alone (prob.priors is `priors`, whose prior rows would favour the first)
        priors["f_hz"] = min(
            halves, key=lambda f: float(np.sum(prob.run_residuals(prob.scaled(f, priors["zeta"])) ** 2))
        )
        range_lo, range_hi = PRIORS["f_hz"][2]
        ranges["f_hz"] = (priors["f_hz"] * range_lo, priors["f_hz"] * range_hi)
    lo_f, hi_f = ranges["f_hz"]
    x0 = _best_start(prob, [priors["f_hz"], *(f for f in halves if lo_f < f < hi_f and f != priors["f_hz"])])
    periods = sum(float(d.t_meas[-1] - d.t_meas[0]) for d in prob.data) * priors["f_hz"]
    prob.weight = prior_weight(float(np.sum(prob.run_residuals(x0) ** 2)), periods)
    prob.realign(x0)
    lo, hi = prob.bounds()
    x = np.concatenate([x0, np.zeros(len(poses))])
    sol = least_squares(
        prob.residuals, x, bounds=(lo, hi), jac=prob.jacobian, x_scale="jac", max_nfev=MAX_NFEV, **TOLERANCES
    )
    physical = prob.physical(sol.x)
    f, zeta = physical["f_hz"], physical["zeta"]
    # on its range's edge: within 1 % of the range (the bounded solver approaches a bound without reaching it)
    at_bound = [nm for nm, v, a, b in zip(FITTED, sol.x, lo, hi) if min(v - a, b - v) < 0.01 * (b - a)]
    # without the views the arc reads nothing: it kept its prior, no fitted value to report
    unread = () if views_deg is not None else ("view_arc_deg",)
    params = {k: e for k, e in _estimates(sol, prob, physical, settings.mass_kg, ranges).items() if k not in unread}
    mass = settings.mass_kg or 1.0
    physics = SloshParams.from_modal(2 * math.pi * f, zeta, mass)
    envelope = {k: max(motion_range(d.exc)[k] for d in prob.data) for k in MOTION_QUANTITIES}
    stderr = tuple((k, params[k].stderr) for k in FITTED_ERRORS if k in params)
    model = replace(
        start,
        params=physics,
        drag=physical["drag"],
        wave_share=physical["wave_share"],
        crest_coeff=physical["crest_coeff"],
        rest_tilt_x_deg=physical["rest_tilt_x_deg"],
        rest_tilt_y_deg=physical["rest_tilt_y_deg"],
        view_arc_deg=physical["view_arc_deg"],
        stderr=stderr,
        envelope=tuple(envelope.items()),
    )
    names = names or [s.source for s in signals]
    runs = [validate_run(p, s, model, nm) for p, s, nm in zip(poses, signals, names)]
    decay_model = LiquidModel(decay.params, radius_m, axis_offset_m, smooth_s, views_deg=views_deg)
    decay_runs = [validate_run(p, s, decay_model, nm) for p, s, nm in zip(poses, signals, names)]
    return IOFit(
        model=model,
        parameters=params,
        decay=decay,
        names=names,
        trajectories=[p.source for p in poses],
        lags_s=prob.lags_at(sol.x),
        offsets=prob.offsets(sol.x),
        runs=runs,
        decay_runs=decay_runs,
        at_bound=at_bound,
        n_simulations=prob.n_sim,
        priors={k: v for k, v in priors.items() if k not in unread},
        ranges={k: v for k, v in ranges.items() if k not in unread},
    )


@dataclass(frozen=True)
class IOSettings:
    """How input-output identification (`identify --trajectory`) reads the pose logs beside the signals."""

    axis_offset_m: float = setting_field(0.0, unit="m", metavar="M", group="io")
    """Distance along the container axis from the logged point up to the pendulum pivot (about the liquid surface at
    rest; -3 to 3 m)."""
    pose_columns: str | None = setting_field(None, metavar="NAMES", group="io")
    """A headerless pose log's column names in order, e.g. t,x,y,z,qx,qy,qz,qw (as `sloshid predict` reads them)."""
    smooth_s: float = setting_field(SMOOTH_S, unit="s", metavar="S", group="io")
    """Savitzky-Golay window for the pose log's accelerations."""
    views_deg: float | None = setting_field(None, unit="deg", metavar="DEG", group="io")
    """The wall height is seen in two planes 90 deg apart fixed to the container, the first at this azimuth from its x
    axis (two cameras on the end-effector, as in the shared antisloshing runs: 0); not given: the whole wall's peak."""

    def __post_init__(self) -> None:
        check_axis_offset("axis_offset_m", self.axis_offset_m)
        if self.views_deg is not None and not math.isfinite(self.views_deg):
            raise SettingError("views_deg", f"{{name}} must be a finite angle in degrees, got {self.views_deg:g}.")


def fit_io_files(
    trajectories: list[str],
    signals: list[Signal],
    settings: IdentSettings,
    radius_m: float | None,
    io: IOSettings | None = None,
) -> IOFit:
    """`identify --trajectory`: check the counts and geometry, read the pose logs, fit."""
    io = io or IOSettings()
    if len(trajectories) != len(signals):
        raise SettingError(
            "trajectory",
            f"give one {{name}} per signal, in the same order: {len(signals)} signal(s), "
            f"{len(trajectories)} trajectories.",
        )
    check_in_metres("container_radius_m", radius_m)
    if radius_m is None and any(s.unit == "mm" for s in signals):
        raise SettingError("container_radius_m", "wall heights in mm need the container radius: give {name} (m).")
    poses = [load_pose_log(t, io.pose_columns) for t in trajectories]
    names = [Path(s.source).stem for s in signals]
    return fit_io(poses, signals, radius_m, io.axis_offset_m, io.smooth_s, settings, names, io.views_deg)


def _estimates(
    sol, prob: _Problem, physical: dict[str, float], mass: float | None, ranges: dict[str, tuple[float, float]]
) -> dict[str, Estimate]:
    """The fitted parameters (and omega, l, d from f and zeta) with Newey-West standard errors (per-run blocks; the
    prior rows one more block), mapped from the scaled vector; each interval cut at its physical range (`ranges`)."""
    f, zeta = physical["f_hz"], physical["zeta"]
    data = prob.data
    sizes = np.cumsum([0] + [d.y.size for d in data] + [N_PARAMS])
    blocks = [slice(a, b) for a, b in itertools.pairwise(sizes)]
    periods = [max(round(1.0 / (f * np.median(np.diff(d.t_meas)))), 1) for d in data] + [1]
    cov, _naive, _lags = hac_covariance(sol.jac, sol.fun, blocks, periods)
    d_scaled = np.array([prob.priors["f_hz"] / 10, zeta] + [1.0] * (N_PARAMS - 2))
    se = np.sqrt(np.clip(np.diag(cov)[:N_PARAMS], 0, None)) * d_scaled
    omega, se_w = 2 * math.pi * f, 2 * math.pi * se[0]
    omegas = (2 * math.pi * ranges["f_hz"][0], 2 * math.pi * ranges["f_hz"][1])
    out = {
        "f_hz": estimate(f, se[0], ranges["f_hz"]),
        "omega_rad_s": estimate(omega, se_w, omegas),
        "zeta": estimate(zeta, se[1], ranges["zeta"]),
        "l_m": estimate(G / omega**2, 2 * G / omega**3 * se_w, (G / omegas[1] ** 2, G / omegas[0] ** 2)),
        **{k: estimate(physical[k], se[FITTED.index(k)], ranges[k]) for k in FITTED[2:]},
    }
    if mass is not None:
        out["d_ns_per_m"] = estimate(
            2 * mass * omega * zeta, 2 * mass * math.hypot(zeta * se_w, omega * se[1]), (0.0, math.inf)
        )
    return out
