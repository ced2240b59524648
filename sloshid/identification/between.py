"""Do signals identified jointly agree? Each window fitted alone, Cochran's Q test of its f and zeta against their
own intervals, and a random-effects interval when they disagree.

A joint fit gives one f and one zeta with an interval from the pooled residual; runs of one liquid that ring at
different frequencies (a nonlinear liquid at different amplitudes, a changed fill level, another container) still
give a narrow joint interval that excludes most of them. The test asks whether the runs' own estimates scatter more
than their standard errors allow; when they do (p < HETEROGENEITY_P), the between-run spread (DerSimonian-Laird tau)
is added to each run's variance, and the joint interval is widened to the random-effects standard error of their
mean, with the distance between that mean and the joint estimate added as a systematic error (as the encoder
hold's shift is): the interval of the liquid's f says what the runs say. Where one more run may land is wider: the
prediction interval (mean +- 1.96 sqrt(tau^2 + se^2)), which compare's robustness band takes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from sloshid.identification.pt2fit import Z95, PT2Fit, WindowData, fit_pt2, fit_pt2_hold, fit_two_modes

HETEROGENEITY_P = 0.01
"""Below this p-value of Cochran's Q the signals disagree: the joint interval is widened to the random-effects one."""
PARAMETERS = ("omega_rad_s", "zeta")
"""The fitted parameters tested, in the order of the fit's covariance."""


@dataclass(frozen=True)
class Agreement:
    """How the single-signal estimates of one parameter agree (Cochran's Q, DerSimonian-Laird tau)."""

    values: tuple[float, ...]
    stderrs: tuple[float, ...]
    q: float
    """Cochran's Q: the inverse-variance weighted sum of squared deviations from the weighted mean."""
    dof: int
    p: float
    """Chance of a Q this large when every signal measures the same value (chi-squared, dof degrees of freedom)."""
    tau: float
    """Between-signal standard deviation beyond the signals' own errors (DerSimonian-Laird; 0 when Q <= dof)."""
    stderr: float
    """Random-effects standard error of the signals' mean (the fixed-effect one when tau is 0)."""
    mean: float = math.nan
    """The random-effects mean (weights 1 / (se^2 + tau^2))."""

    @property
    def prediction95(self) -> tuple[float, float]:
        """Where one more signal's value may land (95 %, normal quantile): mean +- 1.96 sqrt(tau^2 + stderr^2), from
        0 up (a frequency or a damping ratio is positive)."""
        half = Z95 * math.sqrt(self.tau**2 + self.stderr**2)
        return max(self.mean - half, 0.0), self.mean + half

    @property
    def disagree(self) -> bool:
        """The signals scatter more than their intervals allow."""
        return self.p < HETEROGENEITY_P

    def to_dict(self, scale: float = 1.0) -> dict:
        """The JSON form, values in the unit `scale` turns them into (e.g. 1 / 2 pi for omega to f)."""
        return {
            "per_signal": [v * scale for v in self.values],
            "per_signal_stderr": [s * scale for s in self.stderrs],
            "cochran_q": self.q,
            "dof": self.dof,
            "p": self.p,
            "tau": self.tau * scale,
            "random_effects_mean": self.mean * scale,
            "random_effects_stderr": self.stderr * scale,
            "prediction_interval95": [v * scale for v in self.prediction95],
            "disagree": self.disagree,
        }


@dataclass(frozen=True)
class BetweenSignals:
    """The agreement of jointly identified signals on omega and zeta, and how far the joint intervals were widened."""

    omega: Agreement
    zeta: Agreement
    widened: tuple[float, float]
    """Factors the joint standard errors of omega and zeta were multiplied by (1: kept)."""

    def note(self, names: list[str]) -> str | None:
        """The sentence for the report when the signals disagree on f or zeta, else None."""
        parts = []
        for name, a, scale, unit, factor, fmt in (
            ("f", self.omega, 1 / (2 * math.pi), " Hz", self.widened[0], ".4g"),
            ("zeta", self.zeta, 1.0, "", self.widened[1], ".2g"),
        ):
            if not a.disagree:
                continue
            lo, hi = int(np.argmin(a.values)), int(np.argmax(a.values))
            shown = [round(a.values[i] * scale, 6) for i in (lo, hi)]  # a zeta on its bound 0 reads 0
            parts.append(
                f"{name} from {shown[0]:{fmt}}{unit} ({names[lo]}) to {shown[1]:{fmt}}{unit} ({names[hi]}), Cochran's "
                f"Q = {a.q:.3g} on {a.dof} degree{'s' if a.dof > 1 else ''} of freedom (p = {a.p:.2g}), a spread of {a.tau * scale:.2g}{unit} "
                "between signals beyond their own errors"
                + (
                    f"; its interval is widened {factor:.2g}-fold to take in the random-effects mean's"
                    if factor > 1
                    else ""
                )
                + "; one more run may land in {:{fmt}}-{:{fmt}}{} (95 % prediction interval)".format(
                    *(v * scale for v in a.prediction95), unit, fmt=fmt
                )
            )
        if not parts:
            return None
        return (
            f"fitted alone, the {len(names)} signals disagree beyond their own intervals: "
            + "; ".join(parts)
            + ". The liquid rang differently from run to run (another amplitude, fill or container)."
        )

    def summary(self) -> str:
        """One line for the command's summary: the single-signal ranges, and whether they agree."""
        f = [v / (2 * math.pi) for v in self.omega.values]
        z = [round(v, 6) for v in self.zeta.values]
        verdicts = [
            f"{name} {'disagree' if a.disagree else 'agree'} (p = {a.p:.2g})"
            + (f", interval widened {factor:.2g}-fold" if factor > 1 else "")
            for name, a, factor in (("f", self.omega, self.widened[0]), ("zeta", self.zeta, self.widened[1]))
        ]
        return f"signals fitted alone: f {min(f):.4g}-{max(f):.4g} Hz, zeta {min(z):.2g}-{max(z):.2g}; " + "; ".join(
            verdicts
        )

    def to_dict(self) -> dict:
        """The JSON form (`fit.between_signals` of the identify JSON)."""
        return {
            "test": "each window fitted alone; Cochran's Q of the estimates against their own standard errors; "
            f"DerSimonian-Laird random effects when p < {HETEROGENEITY_P:g}",
            "f_hz": self.omega.to_dict(1 / (2 * math.pi)),
            "zeta": self.zeta.to_dict(),
            "stderr_widened_by": dict(zip(("f_hz", "zeta"), self.widened)),
        }


def agreement(values: np.ndarray, stderrs: np.ndarray) -> Agreement:
    """Cochran's Q and the DerSimonian-Laird random-effects mean's standard error of estimates with standard errors."""
    w = 1 / stderrs**2
    mean = float(w @ values / w.sum())
    q = float(w @ (values - mean) ** 2)
    dof = values.size - 1
    tau2 = max(0.0, (q - dof) / (w.sum() - (w @ w) / w.sum()))
    w_re = 1 / (stderrs**2 + tau2)
    return Agreement(
        tuple(map(float, values)),
        tuple(map(float, stderrs)),
        q,
        dof,
        float(stats.chi2.sf(q, dof)),
        math.sqrt(tau2),
        float(1 / math.sqrt(w_re.sum())),
        float(w_re @ values / w_re.sum()),
    )


def fit_alone(window: WindowData, joint: PT2Fit, omega_rad_s: float) -> PT2Fit:
    """One window fitted with the joint fit's model (second mode, encoder hold, zero), searched around its own
    spectral peak `omega_rad_s` (a run of another liquid lies outside the joint fit's +-25 %) and the joint value;
    each step polishes only its best start."""
    starts = [omega_rad_s, joint.omega_rad_s]
    fit = fit_pt2([window], starts, joint.zeta or None, joint.drift, joint.slow_s, keep=1)
    if joint.second is not None:
        fit = fit_two_modes([window], fit, joint.second.omega_rad_s, keep=1)
    return fit_pt2_hold([window], fit, keep=1) if joint.hold is not None else fit


def between_signals(
    windows: list[WindowData], joint: PT2Fit, peaks_rad_s: list[float]
) -> tuple[PT2Fit, BetweenSignals | None]:
    """The joint fit with its covariance widened where the windows, fitted alone (each around its spectral peak in
    `peaks_rad_s`), disagree; and that test (None for a single window, or when a window's fit has no finite error)."""
    if len(windows) < 2:
        return joint, None
    alone = [fit_alone(w, joint, peak) for w, peak in zip(windows, peaks_rad_s)]
    values = np.array([[f.omega_rad_s, f.zeta] for f in alone])
    stderrs = np.sqrt(np.array([np.diag(f.cov) for f in alone]))
    if not (np.isfinite(stderrs).all() and (stderrs > 0).all()):
        return joint, None
    tests = [agreement(values[:, k], stderrs[:, k]) for k in range(2)]
    joint_se = np.sqrt(np.diag(joint.cov))
    joint_x = (joint.omega_rad_s, joint.zeta)
    # the random-effects error of the mean, and how far that mean lies from the joint estimate, as a systematic error
    wanted = [math.hypot(t.stderr, t.mean - x) for t, x in zip(tests, joint_x)]
    factor = np.array([max(1.0, w / s) if t.disagree and s > 0 else 1.0 for t, w, s in zip(tests, wanted, joint_se)])
    test = BetweenSignals(tests[0], tests[1], (float(factor[0]), float(factor[1])))
    if (factor == 1).all():
        return joint, test
    return replace(joint, cov=joint.cov * np.outer(factor, factor)), test
