"""Prediction against measurement: clock alignment by cross-correlation over the move, and the system-identification
scores (NRMSE fit %, peak error %) over the whole record and per phase (during the move, after it)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.spectrum import to_uniform
from sloshid.identification.pt2fit import nrmse_fit_percent

TEMPLATE_PAD_S = (0.5, 2.0)
"""The alignment template runs from 0.5 s before the move to 2 s after it (the slosh the move leaves)."""
LEAD_IN_S = 1.0
"""Scores start this long before the move; the baseline is the median of the quiet record before that."""
MIN_TEMPLATE_SAMPLES = 8


@dataclass(frozen=True)
class Alignment:
    """Measured time = trajectory time + lag_s; correlation is the Pearson r of the template at that lag."""

    lag_s: float
    correlation: float


def align(
    t_meas: np.ndarray,
    y_meas: np.ndarray,
    t_pred: np.ndarray,
    y_pred: np.ndarray,
    move_s: tuple[float, float],
    source: str = "",
) -> Alignment:
    """Slide the predicted move over the measured record; the lag of the highest Pearson correlation, sub-sample.
    `source` (the measured file) names the record in an error."""
    u = to_uniform(t_meas, y_meas)
    dt = 1.0 / u.fs_hz
    t_tpl = np.arange(move_s[0] - TEMPLATE_PAD_S[0], move_s[1] + TEMPLATE_PAD_S[1], dt)
    tpl = np.interp(t_tpl, t_pred, y_pred, left=y_pred[0], right=y_pred[-1])
    m, n = tpl.size, u.value.size
    if m < MIN_TEMPLATE_SAMPLES or n <= m:
        move = move_s[1] - move_s[0]
        raise UserError(
            f"{f'{source}: ' if source else ''}the measured record ({u.t_s[-1] - u.t_s[0]:.2f} s) is too short to "
            f"align with the {move:.2f} s move: it must be longer than the move with {TEMPLATE_PAD_S[0]:g} s before "
            f"and {TEMPLATE_PAD_S[1]:g} s after it ({move + sum(TEMPLATE_PAD_S):.2f} s)."
        )
    tpl = tpl - tpl.mean()
    if not np.any(tpl):
        raise UserError("the prediction is flat over the move (no slosh), so there is nothing to align on.")
    # the record held at its last value for the template's after-move part: a record that ends under 2 s after the
    # move could not hold the template at its true lag, and the best full fit lay a ripple off (4.88 s for 5.00 s)
    x = np.concatenate([u.value, np.full(round(TEMPLATE_PAD_S[1] / dt), u.value[-1])])
    num = np.correlate(x, tpl, mode="valid")  # sum over the window of x * template (template mean removed)
    c1, c2 = np.concatenate([[0.0], np.cumsum(x)]), np.concatenate([[0.0], np.cumsum(x * x)])
    var = (c2[m:] - c2[:-m]) - (c1[m:] - c1[:-m]) ** 2 / m
    r = num / np.sqrt(np.maximum(var, 1e-300) * np.sum(tpl * tpl))
    k = int(np.argmax(r))
    shift = 0.0
    if 0 < k < r.size - 1:  # parabola through the peak and its neighbours
        denom = r[k - 1] - 2 * r[k] + r[k + 1]
        shift = 0.5 * (r[k - 1] - r[k + 1]) / denom if denom < 0 else 0.0
    lag = u.t_s[0] + (k + shift) * dt - t_tpl[0]
    return Alignment(float(lag), float(r[k]))


def baseline(t_meas: np.ndarray, y_meas: np.ndarray, move_start_meas_s: float) -> float:
    """Median of the quiet lead-in before the move (at least 1 s of it), else of the record's first tenth."""
    quiet = y_meas[t_meas < move_start_meas_s - LEAD_IN_S]
    if quiet.size and t_meas[quiet.size - 1] - t_meas[0] >= 1.0:
        return float(np.median(quiet))
    return float(np.median(y_meas[: max(y_meas.size // 10, 1)]))


@dataclass(frozen=True)
class PhaseScore:
    """Scores of one phase: NRMSE fit %, peak error % (predicted peak over measured peak, minus 1), the peaks."""

    fit_percent: float
    peak_error_percent: float
    peak_measured: float
    peak_predicted: float
    n_samples: int

    def to_dict(self) -> dict[str, float | int]:
        """Plain numbers for JSON."""
        return {
            "fit_percent": self.fit_percent,
            "peak_error_percent": self.peak_error_percent,
            "peak_measured": self.peak_measured,
            "peak_predicted": self.peak_predicted,
            "n_samples": self.n_samples,
        }


def score(y: np.ndarray, yhat: np.ndarray) -> PhaseScore:
    """Fit % and peak error % of one stretch (nan when it holds fewer than 3 samples)."""
    if y.size < 3:
        nan = float("nan")
        return PhaseScore(nan, nan, nan, nan, int(y.size))
    peak, peak_hat = float(np.max(y)), float(np.max(yhat))
    error = 100.0 * (peak_hat - peak) / peak if peak > 0 else float("nan")
    fit = nrmse_fit_percent(y, yhat)
    return PhaseScore(fit if math.isfinite(fit) else float("nan"), error, peak, peak_hat, int(y.size))
