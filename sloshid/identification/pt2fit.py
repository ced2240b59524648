"""Least-squares fit of a damped PT2 free response to one or several windows (shared omega and zeta), optionally
with a second damped mode beside it (shared omega2, zeta2) when the spectrum shows one.

Model per window (t' = t - window start):  y = exp(-zeta omega t') (a cos(omega_d t') + b sin(omega_d t')) + c [+ r t']
[+ exp(-zeta2 omega2 t') (a2 cos(omega2_d t') + b2 sin(omega2_d t'))], omega_d = omega sqrt(1 - zeta^2); for a zero
that moves slowly (a sway) the constant c [+ r t'] is a cubic spline with knots some mode periods apart instead.
Standard errors come from a Newey-West (Bartlett kernel) sandwich covariance, which stays honest when residuals are
serially correlated (video tracking noise, unmodelled harmonics).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal, overload

import numpy as np
from scipy import interpolate, optimize, stats

from sloshid.core.errors import UserError

Z95 = float(stats.norm.ppf(0.975))
"""Two-sided 95 % normal quantile used for every interval."""

ZETA_BOUNDS = (0.0, 0.95)
OMEGA_SPAN = 0.25
"""omega is searched within +-25 % of the spectral estimate (the PSD is good to a fraction of a bin)."""
ZETA_STARTS = (0.003, 0.02, 0.08, 0.3)
SPLINE_SAMPLES = 8
"""A slow zero's spline gets at most one knot interval per this many samples of its window, so that each of its
coefficients rests on data (a 16-sample window at 30 fps holds two)."""
HOLD_STARTS = (0.0, 0.5, 1.0, 2.0)
"""Starting hold half-widths, in residual rms of the plain fit (a perfect play leaves about 0.4 of its width)."""
SHRINK_STARTS = (0.0, 0.5, 1.0, 2.0)
"""Starting codec shrinks (`fit_pt2_shrink`), in residual rms of the held fit."""
SHRINK_MAX_SHARE = 0.05
"""Largest codec shrink searched, as a share of the smallest window's starting amplitude (H.264 took 1.5-4 % off
rendered floats'): beyond it, a window that decays little trades zeta for a shrink no codec makes."""
CODEC_ZETA_SHARE = 0.01
"""Systematic standard error of a video-tracked zeta, as a share of zeta: a codec also shrinks the smallest swings,
which the hold does not model, and zeta comes out high by a percent or two at H.264 CRF 16-20. Chosen on the
benchmark's calibration set and twelve plain rendered floats (seed 77): zeta intervals covered the truth trace's value
in 17 of 20 and 5 of 12 without it, 19 and 11 with it (0.5 %: 18, 9; 1.25 %: 20, 12); the held-out set 18 -> 20 of 20.
Now the share of a tracked surface (a float's is FLOAT_CODEC_ZETA_SHARE)."""
FLOAT_CODEC_ZETA_SHARE = 0.025
"""CODEC_ZETA_SHARE for a tracked float (any signal of the fit tracked on a float), whose small swings a codec can lose
in the decoded pictures: on the painted float of benchmarks/track_pbr.py (30 fps, 3.44 Hz,
zeta 0.07, 5 deg, H.264 CRF 20) the tracked swing's gain falls from 1.00 above 2 deg to 0.86 below 1 deg (a plain moment
measurement of the decoded pictures alike; 1.00-1.03 losslessly), and zeta reads 11 % high. Its interval, and that
measured against the container, missed the truth at 1 %; on 14 painted float clips (seeds, CRF 16-23, 30 and 60 fps,
a lossless control; 15 runs with that container run) every interval covers the truth at 2.5 % (13 of 15 at 1 %, 14 at
2 %). Floats of the tracking benchmark's dynamics sets: covered 20 of 20 either way, median half-width 5.5 -> 7.1 %
(docs/design/zeta_from_video.md).
Tracked surfaces showed no such loss (pbr and painted: covered at 1 %) and keep CODEC_ZETA_SHARE."""


@dataclass(frozen=True)
class WindowData:
    """One window to fit: times (s), values (any unit), and the window start that the model's t' counts from."""

    t_s: np.ndarray
    value: np.ndarray
    t0_s: float
    restarts: np.ndarray | None = None
    """Video-tracked signals: True at the samples where the encoder's hold restarts (the first after a key frame,
    a picture coded without reference to the previous ones); None: it never does."""


@dataclass(frozen=True)
class ModeFit:
    """A second damped mode fitted beside the main one: omega, zeta and their 2x2 corrected covariance."""

    omega_rad_s: float
    zeta: float
    cov: np.ndarray


@dataclass(frozen=True)
class HoldFit:
    """The encoder hold fitted jointly with the mode (`fit_pt2_hold`): its half-width, and what fitting it changed."""

    width: float
    """Half-width of the hold, in the signal's unit."""
    width_se: float
    """Its standard error (the same Newey-West covariance as omega and zeta)."""
    shift: np.ndarray
    """(omega, zeta) of the fit with the hold minus those of the plain fit; also a systematic standard error in cov."""
    plain_cov: np.ndarray
    """2x2 covariance of (omega, zeta) of the plain fit, for comparison."""
    weight: float = 1.0
    """Akaike weight of the held model against the plain one (`hold_weight`): the values are plain + weight * shift."""
    restarts: int = 0
    """How many times the hold restarted at a key frame inside the windows (0: no key frames known)."""
    shrink: float = 0.0
    """Amount every swing of the main mode loses to the codec in the refit of `fit_pt2_shrink`, in the signal's unit."""
    shrink_shift: float = 0.0
    """zeta of the refit with the shrink minus the held fit's: a systematic error of zeta (`fit_pt2_shrink`)."""
    shrink_hidden: float = 0.0
    """How far the refit's zeta moves when the shrink grows by the residual's rms: a systematic error of zeta too."""


@dataclass(frozen=True, kw_only=True)
class PT2Fit:
    """Result of the (joint) PT2 fit with its corrected covariance."""

    omega_rad_s: float
    zeta: float
    cov: np.ndarray
    """2x2 covariance of (omega, zeta), Newey-West corrected."""
    cov_naive: np.ndarray
    """2x2 covariance assuming white residuals (s^2 (J'J)^-1), kept to show how much the correction widened it."""
    linear: tuple[np.ndarray, ...]
    """Per window: (a, b, zero's[, a2, b2]): the zero's are c[, r], or the spline coefficients (`zero_columns`)."""
    linear_se: tuple[np.ndarray, ...]
    fitted: tuple[np.ndarray, ...]
    residuals: tuple[np.ndarray, ...]
    hac_lags: tuple[int, ...]
    drift: bool
    at_bound: tuple[str, ...]
    """Names of parameters that ended on a search bound."""
    n_starts: int
    second: ModeFit | None = None
    """The second mode when the model had one."""
    second_fitted: tuple[np.ndarray, ...] = ()
    """Per window: the second mode's part of `fitted` (empty without a second mode)."""
    hold: HoldFit | None = None
    """Video-tracked signals: the encoder hold fitted with the mode (None for other signals)."""
    slow_s: float | None = None
    """Knot spacing (s) of the spline fitted as the signal's zero when it moves slowly; None: a constant [+ drift]."""
    zero_fitted: tuple[np.ndarray, ...] = ()
    """Per window: the fitted zero (offset [+ drift], or the slow spline) at the window's samples."""

    def fit_percent(self, i: int, values: np.ndarray) -> float:
        """NRMSE fit in percent (100 = perfect, 0 = no better than the mean) of window i."""
        return nrmse_fit_percent(values, self.fitted[i])

    def amplitude(self, i: int, mode: int = 0) -> float:
        """Oscillation amplitude of mode 0 (main) or 1 (second) at the start of window i (value unit)."""
        a, b = self.linear[i][_mode_cols(mode, len(self.linear[i]))]
        return float(np.hypot(a, b))

    def amplitude_se(self, i: int, mode: int = 0) -> float:
        """Standard error of that amplitude (delta method, a and b treated as independent)."""
        cols = _mode_cols(mode, len(self.linear[i]))
        a, b = self.linear[i][cols]
        sa, sb = self.linear_se[i][cols]
        amp = np.hypot(a, b)
        return float(np.sqrt((a * sa) ** 2 + (b * sb) ** 2) / amp) if amp > 0 else float("inf")


def encoder_hold(x: np.ndarray, width: float, restarts: np.ndarray | None = None) -> np.ndarray:
    """x seen through a hold (play, backlash) of half-width `width`: the output moves only once x is `width` past it,
    as a video encoder keeps an edge that moved less than its quantiser codes (see fit_pt2_hold). Where `restarts` is
    True the output is x itself: a key frame is coded afresh, without the previous pictures it could hold on to."""
    return _hold_path(x, width, restarts)[0]


def _hold_path(
    x: np.ndarray, width: float, restarts: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """encoder_hold with its derivative structure: output k equals x[src[k]] + sign[k] * width (sign 0 while the
    output still holds the first sample or the last restart's), so the hold's Jacobian is a row selection plus a
    column of signs."""
    out, src, sign = np.empty_like(x), np.zeros(x.size, int), np.zeros(x.size)
    fresh = np.zeros(x.size, bool) if restarts is None else restarts
    held, j, s = x[0], 0, 0.0
    for k, value in enumerate(x):
        if fresh[k]:
            held, j, s = value, k, 0.0
        elif value - width > held:
            held, j, s = value - width, k, -1.0
        elif value + width < held:
            held, j, s = value + width, k, 1.0
        out[k], src[k], sign[k] = held, j, s
    return out, src, sign


def _mode_cols(mode: int, n_lin: int) -> list[int]:
    """Positions of a mode's (a, b) in a window's linear parameters: the main mode first, a second mode last."""
    return [0, 1] if mode == 0 else [n_lin - 2, n_lin - 1]


def nrmse_fit_percent(y: np.ndarray, yhat: np.ndarray) -> float:
    """100 (1 - |y - yhat| / |y - mean(y)|), the system-identification 'fit %'."""
    denom = np.linalg.norm(y - np.mean(y))
    return float(100 * (1 - np.linalg.norm(y - yhat) / denom)) if denom > 0 else float("-inf")


def _damped(t_rel: np.ndarray, omega: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """The two columns exp(-zeta omega t) cos(omega_d t) and exp(-zeta omega t) sin(omega_d t) of one mode."""
    sigma, wd = zeta * omega, omega * np.sqrt(1 - zeta * zeta)
    e = np.exp(-sigma * t_rel)
    return e * np.cos(wd * t_rel), e * np.sin(wd * t_rel)


def zero_columns(t_rel: np.ndarray, drift: bool, slow_s: float | None) -> np.ndarray:
    """Columns of a window's zero (its resting level): a constant [and t' for a drift], or, with `slow_s`, the clamped
    cubic B-splines with knots evenly spaced at most slow_s apart over the window (0.5-1 slow_s), and at least
    SPLINE_SAMPLES samples per knot interval. The splines hold constants and lines and follow a zero that moves
    slowly (a container swaying in the picture); their first coefficient is the zero at the window's start. They
    could represent part of a decaying mode too (most in the first interval, where the clamped end splines are
    free), but the mode is fitted beside them: that costs precision (about 2 % of f's standard error with knots
    1-2 mode periods apart), not accuracy."""
    if slow_s is None:
        return np.column_stack([np.ones_like(t_rel), t_rel] if drift else [np.ones_like(t_rel)])
    span = float(t_rel[-1])
    intervals = min(math.ceil(span / slow_s), t_rel.size // SPLINE_SAMPLES)
    inner = np.linspace(0.0, span, max(1, intervals) + 1)
    knots = np.concatenate([[0.0] * 3, inner, [span] * 3])
    return interpolate.BSpline.design_matrix(np.clip(t_rel, 0.0, span), knots, 3).toarray()


def _basis(t_rel: np.ndarray, modes: np.ndarray, zero: np.ndarray) -> np.ndarray:
    """Columns multiplying the linear parameters (a, b, zero's[, a2, b2]) for given modes [(omega, zeta), ...] and
    the window's `zero_columns`."""
    cols = [*_damped(t_rel, *modes[0]), zero]
    for omega, zeta in modes[1:]:
        cols += _damped(t_rel, omega, zeta)
    return np.column_stack(cols)


class _JointModel:
    """Residuals and analytic Jacobian of the stacked windows for x = (omega, zeta[, omega2, zeta2], lin_1, ..., lin_K)."""

    n_extra = 0
    """Number of parameters after the linear ones (the hold's width in _HeldModel)."""

    def __init__(self, windows: list[WindowData], drift: bool, n_modes: int = 1, slow_s: float | None = None):
        self.t = [w.t_s - w.t0_s for w in windows]
        self.y = [w.value for w in windows]
        self.restarts = [w.restarts for w in windows]
        self.n_modes = n_modes
        self.nq = 2 * n_modes
        """Number of nonlinear parameters (omega, zeta per mode)."""
        self.drift, self.slow_s = drift, slow_s
        self.zero = [zero_columns(t, drift, slow_s) for t in self.t]
        self.nl = [2 + z.shape[1] + 2 * (n_modes - 1) for z in self.zero]
        """Number of linear parameters of each window."""
        self.offsets = self.nq + np.cumsum([0, *self.nl[:-1]])
        """Where each window's linear parameters start in the stacked vector."""
        ends = np.cumsum([0] + [t.size for t in self.t])
        self.blocks = [slice(a, b) for a, b in itertools.pairwise(ends)]
        """Rows of each window in the stacked residual vector."""

    def modes(self, x: np.ndarray) -> np.ndarray:
        """(omega, zeta) per mode from the stacked vector."""
        return x[: self.nq].reshape(self.n_modes, 2)

    def split(self, x: np.ndarray) -> list[np.ndarray]:
        """Per-window linear parameters from the stacked vector."""
        return [x[o : o + nl] for o, nl in zip(self.offsets, self.nl)]

    def fitted(self, x: np.ndarray) -> list[np.ndarray]:
        """Model values per window."""
        return [_basis(t, self.modes(x), z) @ lin for t, z, lin in zip(self.t, self.zero, self.split(x))]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Model minus data, all windows stacked."""
        return np.concatenate([f - y for f, y in zip(self.fitted(x), self.y)])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d residuals / d x, analytic."""
        modes = self.modes(x)
        jac = np.zeros((self.blocks[-1].stop, x.size))
        for k, (t, lin, rows) in enumerate(zip(self.t, self.split(x), self.blocks)):
            for m, (omega, zeta) in enumerate(modes):
                a, b = lin[_mode_cols(m, self.nl[k])]
                root = np.sqrt(max(1 - zeta * zeta, 1e-12))
                sigma, wd = zeta * omega, omega * root
                e = np.exp(-sigma * t)
                c, s = np.cos(wd * t), np.sin(wd * t)
                d_sigma = -t * e * (a * c + b * s)
                d_wd = e * t * (-a * s + b * c)
                jac[rows, 2 * m] = d_sigma * zeta + d_wd * root
                jac[rows, 2 * m + 1] = d_sigma * omega - d_wd * omega * zeta / root
            jac[rows, self.offsets[k] : self.offsets[k] + self.nl[k]] = _basis(t, modes, self.zero[k])
        return jac

    def linear_start(self, q: tuple[float, ...]) -> np.ndarray:
        """Best linear parameters for fixed nonlinear ones q (variable projection), stacked behind q."""
        modes = np.reshape(q[: self.nq], (self.n_modes, 2))
        lins = [np.linalg.lstsq(_basis(t, modes, z), y, rcond=None)[0] for t, z, y in zip(self.t, self.zero, self.y)]
        return np.concatenate([q[: self.nq], *lins, q[self.nq :]])

    def cost(self, q: tuple[float, ...]) -> float:
        """Sum of squared residuals after variable projection (the screen for starting points)."""
        return float(np.sum(self.residuals(self.linear_start(q)) ** 2))


class _HeldModel(_JointModel):
    """The joint model seen through one encoder hold (`encoder_hold`, shared by all windows) whose half-width is the
    last parameter; the linear start ignores the hold (it is a small distortion of the same decay)."""

    n_extra = 1

    def fitted(self, x: np.ndarray) -> list[np.ndarray]:
        """Model values per window, through the hold."""
        return [_hold_path(f, x[-1], r)[0] for f, r in zip(super().fitted(x), self.restarts)]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d residuals / d x: the plain Jacobian's rows of the samples the hold passes on, and the hold's signs."""
        jac = super().jacobian(x)
        for f, rows, restarts in zip(super().fitted(x), self.blocks, self.restarts):
            _, src, sign = _hold_path(f, x[-1], restarts)
            jac[rows] = jac[rows][src]
            jac[rows, -1] = sign
        return jac


class _ShrunkHeldModel(_HeldModel):
    """The held model whose main mode loses `shrink` (second last parameter, shared by all windows) of its amplitude
    A(t') = hypot(a, b) exp(-zeta omega t') at every moment, down to nothing where A < shrink (`fit_pt2_shrink`):
    the mode becomes max(exp(-zeta omega t') - shrink / hypot(a, b), 0) (a cos(omega_d t') + b sin(omega_d t'))."""

    n_extra = 2

    @overload
    def _unheld(self, x: np.ndarray, jacobian: Literal[True] = ...) -> tuple[list[np.ndarray], np.ndarray]: ...
    @overload
    def _unheld(self, x: np.ndarray, jacobian: Literal[False]) -> tuple[list[np.ndarray], None]: ...
    def _unheld(self, x: np.ndarray, jacobian: bool = True) -> tuple[list[np.ndarray], np.ndarray | None]:
        """Model values per window before the hold, and (when asked) their Jacobian with the hold's width column
        zero: the plain model's, with the main mode's columns (omega, zeta, a, b) and the shrink's for the shrunk
        mode."""
        modes, shrink = self.modes(x), x[-2]
        (omega, zeta), root = modes[0], np.sqrt(max(1 - modes[0][1] ** 2, 1e-12))
        jac = _JointModel.jacobian(self, x) if jacobian else None
        values = []
        for t, z, lin, rows, o in zip(self.t, self.zero, self.split(x), self.blocks, self.offsets):
            a, b = lin[:2]
            amp = max(float(np.hypot(a, b)), 1e-300)
            e = np.exp(-zeta * omega * t)
            cos, sin = np.cos(omega * root * t), np.sin(omega * root * t)
            wave = a * cos + b * sin
            gain = np.maximum(e - shrink / amp, 0.0)
            values.append(_basis(t, modes, z) @ lin - (e - gain) * wave)
            if jac is None:
                continue
            on = gain > 0
            d_sigma, d_wd = -t * e * wave * on, gain * t * (b * cos - a * sin)
            jac[rows, 0] = d_sigma * zeta + d_wd * root
            jac[rows, 1] = d_sigma * omega - d_wd * omega * zeta / root
            jac[rows, o] = gain * cos + on * wave * shrink * a / amp**3
            jac[rows, o + 1] = gain * sin + on * wave * shrink * b / amp**3
            jac[rows, -2] = -wave * on / amp
        return values, jac

    def fitted(self, x: np.ndarray) -> list[np.ndarray]:
        """Model values per window: shrunk, then through the hold."""
        return [_hold_path(f, x[-1], r)[0] for f, r in zip(self._unheld(x, jacobian=False)[0], self.restarts)]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d residuals / d x: the shrunk model's rows of the samples the hold passes on, and the hold's signs."""
        values, jac = self._unheld(x)
        for f, rows, restarts in zip(values, self.blocks, self.restarts):
            _, src, sign = _hold_path(f, x[-1], restarts)
            jac[rows] = jac[rows][src]
            jac[rows, -1] = sign
        return jac


def correlation_lags(r: np.ndarray, period: int) -> int:
    """Newey-West bandwidth: the larger of the textbook rule 4 (N/100)^(2/9) and the lag after which the residual
    autocorrelation stays inside +-3/sqrt(N) for a whole mode period (`period` samples), so that periodic
    leftovers (nonlinear crests, a second mode) widen the intervals instead of hiding; at most N/4."""
    n = r.size
    cap = n // 4
    rule = int(np.floor(4 * (n / 100) ** (2 / 9)))
    acf = autocorrelation(r, min(n - 1, cap + period))
    outside = np.flatnonzero(np.abs(acf[1:]) >= 3 / np.sqrt(n)) + 1
    last = 0
    for lag in outside:  # the first run of `period` quiet lags ends the correlated part
        if lag - last > period:
            break
        last = int(lag)
    return int(min(max(rule, last), cap))


def autocorrelation(r: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation of r at lags 0..max_lag (FFT, biased estimator as in Box-Jenkins)."""
    x = r - r.mean()
    n = x.size
    spec = np.fft.rfft(x, 2 * n)
    acov = np.fft.irfft(spec * np.conj(spec))[: max_lag + 1] / n
    return acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)


def long_run_covariance(g: np.ndarray, lag: int) -> np.ndarray:
    """Long-run covariance of score rows g: VAR(1) prewhitening, Bartlett-kernel sum over `lag` lags, recolouring
    (Andrews and Monahan 1992), which keeps small-sample coverage close to nominal under strong correlation."""
    p = g.shape[1]
    scale = np.linalg.norm(g, axis=0)
    scale[scale == 0] = 1.0
    gs = g / scale  # VAR(1) by normal equations on unit-norm columns: as accurate here and far cheaper than lstsq
    b = np.linalg.lstsq(gs[:-1].T @ gs[:-1], gs[:-1].T @ gs[1:], rcond=None)[0]
    a = b.T * scale[:, None] / scale[None, :]
    if np.max(np.abs(np.linalg.eigvals(a))) > 0.97:  # near unit root: prewhitening would explode, skip it
        a = np.zeros((p, p))
    e = g[1:] - g[:-1] @ a.T
    meat = e.T @ e
    for k in range(1, lag + 1):
        ek = e[k:].T @ e[:-k]
        meat += (1 - k / (lag + 1)) * (ek + ek.T)
    recolour = np.linalg.inv(np.eye(p) - a)
    return recolour @ meat @ recolour.T * (g.shape[0] / e.shape[0])


def hac_covariance(
    jac: np.ndarray, resid: np.ndarray, blocks: list[slice], periods: list[int]
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Sandwich covariance (J'J)^-1 S (J'J)^-1 with S the long-run covariance of the scores J_t r_t (residuals
    leverage-adjusted as in HC2);
    windows are independent of each other. Returns (corrected covariance, white-noise covariance, lags per window)."""
    n, p = jac.shape
    bread = np.linalg.pinv(jac.T @ jac)
    leverage = np.clip(np.sum((jac @ bread) * jac, axis=1), 0, 0.9)
    adjusted = resid / np.sqrt(1 - leverage)  # HC2: the fit pulls high-leverage residuals toward zero
    meat = np.zeros((p, p))
    lags = []
    for rows, period in zip(blocks, periods):
        used = np.flatnonzero(np.any(jac[rows] != 0, axis=0))
        g = jac[rows][:, used] * adjusted[rows, None]
        lag = correlation_lags(resid[rows], period)
        lags.append(lag)
        meat[np.ix_(used, used)] += long_run_covariance(g, lag)
    dof = n / max(n - p, 1)
    naive = bread * float(resid @ resid) / max(n - p, 1)
    hac = bread @ meat @ bread * dof
    # HAC estimates run low in short records; never report less spread than white residuals would imply
    scale = np.sqrt(np.maximum(np.diag(naive), np.diag(hac)) / np.where(np.diag(hac) > 0, np.diag(hac), 1.0))
    return hac * np.outer(scale, scale), naive, lags


def _solve(
    model: _JointModel,
    starts: Sequence[tuple[float, ...]],
    lower_q: Sequence[float],
    upper_q: Sequence[float],
    keep: int = 5,
    plain: PT2Fit | None = None,
) -> PT2Fit:
    """Screen the starts by variable projection, polish the best `keep` with bounded least squares, keep the lowest
    cost, and attach the corrected covariance. Starts and bounds cover the nonlinear parameters and then any extra
    one (a _HeldModel's width, whose HoldFit compares with the `plain` fit)."""
    nq, ne = model.nq, model.n_extra
    npar = nq + sum(model.nl) + ne
    if model.blocks[-1].stop <= npar:  # as many parameters as samples: a perfect fit with no error left to estimate
        raise UserError(
            f"the fit windows hold {model.blocks[-1].stop} samples for {npar} parameters; a fit needs more samples "
            "than parameters (a longer window)."
        )
    lower, upper = np.full(npar, -np.inf), np.full(npar, np.inf)
    nonlinear = [*range(nq), *range(npar - ne, npar)]
    lower[nonlinear], upper[nonlinear] = lower_q, upper_q
    screened = sorted(starts, key=model.cost)[:keep]
    best = None
    for q in screened:
        x0 = model.linear_start(tuple(np.clip(q, lower_q, upper_q)))
        res = optimize.least_squares(
            model.residuals,
            x0,
            jac=model.jacobian,
            bounds=(lower, upper),
            x_scale="jac",
            method="trf",
            tr_solver="lsmr",
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=200,
        )
        if best is None or res.cost < best.cost:
            best = res
    if best is None:
        raise ValueError("no start to fit the model from (keep must be at least 1)")
    x = best.x
    resid = model.residuals(x)
    jac = model.jacobian(x)
    periods = [max(2, round(2 * np.pi / x[0] / np.median(np.diff(t)))) for t in model.t]
    cov, naive, lags = hac_covariance(jac, resid, model.blocks, periods)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    names = ("omega", "zeta", "omega2", "zeta2")[:nq] + ("hold",) * ne
    at_bound = [
        name
        for name, i in zip(names, nonlinear)
        if x[i] - lower[i] < 1e-6 * (upper[i] - lower[i]) or upper[i] - x[i] < 1e-6 * (upper[i] - lower[i])
    ]
    lins = model.split(x)
    fitted = model.fitted(x)
    second, second_fitted = None, ()
    if model.n_modes == 2:
        second = ModeFit(float(x[2]), float(x[3]), cov[2:4, 2:4])
        second_fitted = tuple(
            np.column_stack(_damped(t, x[2], x[3])) @ lin[_mode_cols(1, nl)]
            for t, lin, nl in zip(model.t, lins, model.nl)
        )
    return PT2Fit(
        omega_rad_s=float(x[0]),
        zeta=float(x[1]),
        cov=cov[:2, :2],
        cov_naive=naive[:2, :2],
        linear=tuple(lins),
        linear_se=tuple(model.split(se)),
        fitted=tuple(fitted),
        residuals=tuple(y - f for y, f in zip(model.y, fitted)),
        hac_lags=tuple(lags),
        drift=model.drift,
        at_bound=tuple(at_bound),
        n_starts=len(screened),
        second=second,
        second_fitted=second_fitted,
        hold=None
        if plain is None
        else HoldFit(
            float(x[-1]),
            float(se[-1]),
            np.array([x[0] - plain.omega_rad_s, x[1] - plain.zeta]),
            plain.cov,
            shrink=float(x[-2]) if ne == 2 else 0.0,
        ),
        slow_s=model.slow_s,
        zero_fitted=tuple(z @ lin[2 : 2 + z.shape[1]] for z, lin in zip(model.zero, lins)),
    )


def fit_pt2(
    windows: list[WindowData],
    omega_starts: list[float],
    zeta_hint: float | None = None,
    drift: bool = False,
    slow_s: float | None = None,
    keep: int = 5,
) -> PT2Fit:
    """Fit the free response jointly to all windows from several starts; keep the lowest cost.

    The first of omega_starts (the spectral estimate) centres the +-25 % search interval for omega; `drift` and
    `slow_s` choose the zero's model (`zero_columns`); the `keep` starts of lowest cost are polished."""
    model = _JointModel(windows, drift, slow_s=slow_s)
    omega0 = omega_starts[0]
    lo_w, hi_w = omega0 * (1 - OMEGA_SPAN), omega0 * (1 + OMEGA_SPAN)
    zetas = sorted({*ZETA_STARTS, *([float(np.clip(zeta_hint, 1e-3, 0.9))] if zeta_hint else [])})
    omegas = [float(np.clip(w * f, lo_w, hi_w)) for w in omega_starts for f in (1.0, 0.99, 1.01)]
    starts = [(w, z) for z in zetas for w in omegas]
    return _solve(model, starts, (lo_w, ZETA_BOUNDS[0]), (hi_w, ZETA_BOUNDS[1]), keep)


def fit_two_modes(windows: list[WindowData], first: PT2Fit, omega2_start: float, keep: int = 3) -> PT2Fit:
    """Fit the main mode and a second damped mode together (second started at the PSD's secondary peak).

    Each mode's omega may move at most half-way toward the other's start, so the two cannot swap or merge; a mode
    that ends on that bound was not separated by the data."""
    model = _JointModel(windows, first.drift, n_modes=2, slow_s=first.slow_s)
    w1 = first.omega_rad_s
    half = abs(omega2_start - w1) / 2
    lower = (max(w1 - half, w1 * (1 - OMEGA_SPAN)), ZETA_BOUNDS[0], omega2_start - half, ZETA_BOUNDS[0])
    upper = (min(w1 + half, w1 * (1 + OMEGA_SPAN)), ZETA_BOUNDS[1], omega2_start + half, ZETA_BOUNDS[1])
    # the main mode starts where the single-mode fit put it; the second from the PSD peak, with several dampings
    starts = [(w1, first.zeta, omega2_start * f2, z2) for z2 in ZETA_STARTS for f2 in (1.0, 0.99, 1.01)]
    return _solve(model, starts, lower, upper, keep)


def with_codec_share(fit: PT2Fit, share: float = CODEC_ZETA_SHARE) -> PT2Fit:
    """The fit with `share` of zeta (CODEC_ZETA_SHARE, FLOAT_CODEC_ZETA_SHARE for a float) added to zeta's variance:
    the codec's shrinking of the smallest swings, the same in every window of one camera and codec. Added to the final
    fit only, after the windows' agreement is judged: in the single-window fits it read as independent errors and hid
    runs that disagree (a review: two floats at zeta 0.030 and 0.0309 went from 'disagree, widened 3-fold' to
    'agree', and the joint interval narrowed)."""
    return replace(fit, cov=fit.cov + np.diag([0.0, (share * fit.zeta) ** 2]))


def codec_zeta_share(targets: Sequence[str]) -> float:
    """The codec's share of zeta for signals tracked on these targets ('float', 'surface'; '' for a signal not
    tracked): FLOAT_CODEC_ZETA_SHARE when any is a float, else CODEC_ZETA_SHARE."""
    return FLOAT_CODEC_ZETA_SHARE if "float" in targets else CODEC_ZETA_SHARE


def fit_pt2_hold(windows: list[WindowData], plain: PT2Fit, keep: int = len(HOLD_STARTS)) -> PT2Fit:
    """The mode (and any second mode) refitted as seen through an encoder hold whose half-width is fitted with it,
    started from the plain fit; for signals tracked in video (`encoder_hold`).

    Inter-frame codecs leave an edge that moved less than their quantiser resolves where it was, so the tracked
    angle trails the slosh by a nearly constant amount that grows relative to the decaying swing: fitted as a plain
    decay, f comes out low and zeta high, while the residual cannot show it (the fit takes the hold's fundamental
    into the mode). The width is searched from 0 to half the smallest window's starting amplitude; its uncertainty
    enters omega's and zeta's through the joint Newey-West covariance. A codec is no perfect hold, so the shift from
    the plain fit is added as a systematic standard error: the distance between the two models is what is known
    about the model's own error (on rendered clips the hold explains most, not all, of the tracking error). The
    values are the two fits averaged by the evidence for the hold (`hold_weight`), since tracking noise alone also
    fits a hold and moves f up; the curve and residuals stay the held fit's. The codec's shrinking of the swings is
    allowed for after (`fit_pt2_shrink`, `with_codec_share`)."""
    model = _HeldModel(windows, plain.drift, 2 if plain.second else 1, plain.slow_s)
    modes, lower, upper, widest = _refit_bounds(windows, plain)
    rms = float(np.sqrt(np.mean(np.concatenate(plain.residuals) ** 2)))
    starts = [(*modes, min(f * rms, widest)) for f in HOLD_STARTS]
    fit = _solve(model, starts, (*lower, 0.0), (*upper, widest), keep, plain=plain)
    hold = _hold(fit)
    weight = hold_weight(hold.width, hold.width_se)
    restarts = sum(int(np.sum(w.restarts)) for w in windows if w.restarts is not None)
    cov = fit.cov + np.outer(hold.shift, hold.shift)
    # the averaged value lies (1 - weight) |shift| from the held fit's: its interval is widened by that much on each
    # side, so that it holds the held fit's interval (which covers the truth whether there is a hold or not)
    sd = np.sqrt(np.diag(cov))
    factor = 1 + (1 - weight) * np.abs(hold.shift) / np.where(sd > 0, Z95 * sd, np.inf)
    return replace(
        fit,
        omega_rad_s=plain.omega_rad_s + weight * float(hold.shift[0]),
        zeta=plain.zeta + weight * float(hold.shift[1]),
        hold=replace(hold, restarts=restarts, weight=weight),
        cov=cov * np.outer(factor, factor),
        # a width of zero is a signal without a hold, not a search that ran out of room
        at_bound=tuple(n for n in fit.at_bound if n != "hold" or hold.width > widest / 2),
    )


def hold_weight(width: float, width_se: float) -> float:
    """Akaike weight of the held model against the plain one, 1 / (1 + exp(1 - z^2 / 2)), z^2 = (width / its Newey-West
    standard error)^2 standing for the likelihood ratio, which white-noise sums of squares overstate in correlated
    tracking noise; tracking noise alone fits a small hold and moves f up (docs/design/zeta_from_video.md)."""
    if width_se <= 0:
        return 1.0 if width > 0 else 0.0
    return 1.0 / (1.0 + math.exp(1.0 - 0.5 * (width / width_se) ** 2))


def _hold(fit: PT2Fit) -> HoldFit:
    """The encoder hold fitted with `fit` (`fit_pt2_hold`)."""
    if fit.hold is None:
        raise ValueError("the fit has no encoder hold: fit it through one first (fit_pt2_hold)")
    return fit.hold


def _refit_bounds(windows: list[WindowData], fit: PT2Fit) -> tuple[list[float], list[float], list[float], float]:
    """For a refit of `fit` through a codec model: its modes (omega, zeta[, omega2, zeta2]), their lower and upper
    bounds (each omega within OMEGA_SPAN, as in fit_two_modes at most half-way toward the other mode), and the
    largest hold width or shrink searched: half the smallest window's starting amplitude."""
    modes = [(fit.omega_rad_s, fit.zeta)] + ([(fit.second.omega_rad_s, fit.second.zeta)] if fit.second else [])
    reach = [OMEGA_SPAN * w for w, _ in modes]
    if fit.second:
        reach = [min(r, abs(modes[1][0] - modes[0][0]) / 2) for r in reach]
    lower = [v for (w, _), r in zip(modes, reach) for v in (w - r, ZETA_BOUNDS[0])]
    upper = [v for (w, _), r in zip(modes, reach) for v in (w + r, ZETA_BOUNDS[1])]
    return list(np.ravel(modes)), lower, upper, 0.5 * min(fit.amplitude(i) for i in range(len(windows)))


def fit_pt2_shrink(windows: list[WindowData], held: PT2Fit, keep: int = 2) -> PT2Fit:
    """The held fit with zeta's variance widened for the codec's shrink of every swing (H.264 takes about the same
    angle off each, with little lag, which the hold cannot model): the zeta shifts of a refit with a fitted constant
    shrink (`_ShrunkHeldModel`) and of one with that shrink a residual rms larger are added as systematic errors. The
    values stay the held fit's: as the value the shrink over-corrected high-bit-rate floats (docs/design/zeta_from_video.md).
    For the final fit only, like `with_codec_share`: one camera and codec shrink every window alike."""
    modes, lower, upper, widest = _refit_bounds(windows, held)
    most = 2 * SHRINK_MAX_SHARE * widest  # widest is half the smallest starting amplitude
    lower, upper = [*lower, 0.0, 0.0], [*upper, most, widest]  # then the shrink and the hold's width
    rms = float(np.sqrt(np.mean(np.concatenate(held.residuals) ** 2)))
    # from the held fit's width and from none: a hold can take a shrink's place in a local minimum
    starts = [(*modes, min(f * rms, most), w) for f in SHRINK_STARTS for w in (_hold(held).width, 0.0)]
    model = _ShrunkHeldModel(windows, held.drift, 2 if held.second else 1, held.slow_s)
    shrunk = _solve(model, starts, lower, upper, keep, plain=held)
    # the same fit with the codec taking another residual rms off every swing, a shrink the fit cannot tell from
    # the one it found (held to that value by bounds a hair apart: least squares wants them apart)
    shrunk_hold = _hold(shrunk)
    more = min(shrunk_hold.shrink + rms, most)
    x_more = (shrunk.omega_rad_s, shrunk.zeta, *modes[2:], more, shrunk_hold.width)
    lower_more, upper_more = list(lower), list(upper)
    lower_more[-2], upper_more[-2] = more, more * (1 + 1e-9) + 1e-12
    hidden = _solve(model, [x_more], lower_more, upper_more, 1).zeta - shrunk.zeta
    shift = shrunk.zeta - held.zeta
    var = held.cov[1, 1]  # with the hold's own shift from a plain fit, a systematic error too
    scale = math.sqrt((var + shift**2 + hidden**2) / var) if var > 0 else 1.0
    return replace(
        held,
        cov=held.cov * np.outer([1.0, scale], [1.0, scale]),
        hold=replace(_hold(held), shrink=shrunk_hold.shrink, shrink_shift=shift, shrink_hidden=hidden),
    )
