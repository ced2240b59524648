"""Least-squares fit of a damped PT2 free response to one or several windows (shared omega and zeta), optionally
with a second damped mode beside it (shared omega2, zeta2) when the spectrum shows one.

Model per window (t' = t - window start):  y = exp(-zeta omega t') (a cos(omega_d t') + b sin(omega_d t')) + c [+ r t']
[+ exp(-zeta2 omega2 t') (a2 cos(omega2_d t') + b2 sin(omega2_d t'))], omega_d = omega sqrt(1 - zeta^2).
Standard errors come from a Newey-West (Bartlett kernel) sandwich covariance, which stays honest when residuals are
serially correlated (video tracking noise, unmodelled harmonics).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
from scipy import optimize, stats

Z95 = float(stats.norm.ppf(0.975))
"""Two-sided 95 % normal quantile used for every interval."""

ZETA_BOUNDS = (0.0, 0.95)
OMEGA_SPAN = 0.25
"""omega is searched within +-25 % of the spectral estimate (the PSD is good to a fraction of a bin)."""
ZETA_STARTS = (0.003, 0.02, 0.08, 0.3)


@dataclass(frozen=True)
class WindowData:
    """One window to fit: times (s), values (any unit), and the window start that the model's t' counts from."""

    t_s: np.ndarray
    value: np.ndarray
    t0_s: float


@dataclass(frozen=True)
class ModeFit:
    """A second damped mode fitted beside the main one: omega, zeta and their 2x2 corrected covariance."""

    omega_rad_s: float
    zeta: float
    cov: np.ndarray


@dataclass(frozen=True)
class PT2Fit:
    """Result of the (joint) PT2 fit with its corrected covariance."""

    omega_rad_s: float
    zeta: float
    cov: np.ndarray
    """2x2 covariance of (omega, zeta), Newey-West corrected."""
    cov_naive: np.ndarray
    """2x2 covariance assuming white residuals (s^2 (J'J)^-1), kept to show how much the correction widened it."""
    linear: tuple[np.ndarray, ...]
    """Per window: (a, b, c[, r][, a2, b2])."""
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
    hold_shift: np.ndarray | None = None
    """Video-tracked signals: the (omega, zeta) shift an encoder hold as wide as the residual rms causes; `cov` holds
    half of it as a systematic standard error (None for other signals)."""
    hold_correction: np.ndarray | None = None
    """The part of -hold_shift already applied to omega and zeta: half of it for a float, none for a surface."""

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


def encoder_hold(x: np.ndarray, width: float) -> np.ndarray:
    """x seen through a hold (play, backlash) of half-width `width`: the output moves only once x is `width` past it,
    as a video encoder keeps an edge that moved less than its quantiser codes (see allow_encoder_hold)."""
    out = np.empty_like(x)
    held = x[0]
    for k, value in enumerate(x):
        held = min(max(held, value - width), value + width)
        out[k] = held
    return out


def allow_encoder_hold(windows: list[WindowData], fit: PT2Fit, correct: bool) -> PT2Fit:
    """The fit with an allowance for a video encoder's hold (`encoder_hold`) in its (omega, zeta) covariance, and
    corrected for half the hold's effect when `correct` (a tracked float).

    Inter-frame codecs leave edges that moved less than their quantiser resolves where they were; the tracked angle
    then lags the slosh by a nearly constant amount, which grows relative to the decaying swing: f comes out low and
    zeta high (issue 12: raw frames of the same clips give neither). The residuals cannot show it, because the fit
    takes its fundamental into the mode, so the HAC covariance alone misses it. The shift a hold as wide as the
    window's residual rms causes (the fitted main mode refitted with and without it) is an empirical scale of the
    bias: on the 10 float clips of benchmarks/track_accuracy.py it was 0.65-3.1 times the tracked trace's f error,
    median 1.9 (white noise in the residual adds to it, a codec's hold is no perfect play), so half of it is
    corrected and that half is the standard error. A surface line moves two to three times more pixels per degree than a float and
    came out unbiased there (its residual holds higher modes and the meniscus): it gets the allowance only."""
    held, clean = [], []
    for w, fitted, resid, second in itertools.zip_longest(windows, fit.fitted, fit.residuals, fit.second_fitted):
        main = fitted - second if second is not None else fitted
        clean.append(WindowData(w.t_s, main, w.t0_s))
        held.append(WindowData(w.t_s, encoder_hold(main, float(np.sqrt(np.mean(resid**2)))), w.t0_s))
    seen, exact = (fit_pt2(d, [fit.omega_rad_s], fit.zeta or None, fit.drift) for d in (held, clean))
    shift = np.array([seen.omega_rad_s - exact.omega_rad_s, seen.zeta - exact.zeta])
    correction = -0.5 * shift if correct else np.zeros(2)
    return replace(
        fit,
        omega_rad_s=fit.omega_rad_s + float(correction[0]),
        zeta=max(fit.zeta + float(correction[1]), 0.0),
        cov=fit.cov + np.outer(shift, shift) / 4,
        hold_shift=shift,
        hold_correction=correction,
    )


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


def _basis(t_rel: np.ndarray, modes: np.ndarray, drift: bool) -> np.ndarray:
    """Columns multiplying the linear parameters (a, b, c[, r][, a2, b2]) for given modes [(omega, zeta), ...]."""
    cols = [*_damped(t_rel, *modes[0]), np.ones_like(t_rel)]
    if drift:
        cols.append(t_rel)
    for omega, zeta in modes[1:]:
        cols += _damped(t_rel, omega, zeta)
    return np.column_stack(cols)


class _JointModel:
    """Residuals and analytic Jacobian of the stacked windows for x = (omega, zeta[, omega2, zeta2], lin_1, ..., lin_K)."""

    def __init__(self, windows: list[WindowData], drift: bool, n_modes: int = 1):
        self.t = [w.t_s - w.t0_s for w in windows]
        self.y = [w.value for w in windows]
        self.n_modes = n_modes
        self.nq = 2 * n_modes
        """Number of nonlinear parameters (omega, zeta per mode)."""
        self.nl = (4 if drift else 3) + 2 * (n_modes - 1)
        self.drift = drift
        ends = np.cumsum([0] + [t.size for t in self.t])
        self.blocks = [slice(a, b) for a, b in itertools.pairwise(ends)]
        """Rows of each window in the stacked residual vector."""

    def modes(self, x: np.ndarray) -> np.ndarray:
        """(omega, zeta) per mode from the stacked vector."""
        return x[: self.nq].reshape(self.n_modes, 2)

    def split(self, x: np.ndarray) -> list[np.ndarray]:
        """Per-window linear parameters from the stacked vector."""
        return [x[self.nq + k * self.nl : self.nq + (k + 1) * self.nl] for k in range(len(self.t))]

    def fitted(self, x: np.ndarray) -> list[np.ndarray]:
        """Model values per window."""
        return [_basis(t, self.modes(x), self.drift) @ lin for t, lin in zip(self.t, self.split(x))]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Model minus data, all windows stacked."""
        return np.concatenate([f - y for f, y in zip(self.fitted(x), self.y)])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d residuals / d x, analytic."""
        modes = self.modes(x)
        jac = np.zeros((self.blocks[-1].stop, x.size))
        for k, (t, lin, rows) in enumerate(zip(self.t, self.split(x), self.blocks)):
            for m, (omega, zeta) in enumerate(modes):
                a, b = lin[_mode_cols(m, self.nl)]
                root = np.sqrt(max(1 - zeta * zeta, 1e-12))
                sigma, wd = zeta * omega, omega * root
                e = np.exp(-sigma * t)
                c, s = np.cos(wd * t), np.sin(wd * t)
                d_sigma = -t * e * (a * c + b * s)
                d_wd = e * t * (-a * s + b * c)
                jac[rows, 2 * m] = d_sigma * zeta + d_wd * root
                jac[rows, 2 * m + 1] = d_sigma * omega - d_wd * omega * zeta / root
            jac[rows, self.nq + k * self.nl : self.nq + (k + 1) * self.nl] = _basis(t, modes, self.drift)
        return jac

    def linear_start(self, q: tuple[float, ...]) -> np.ndarray:
        """Best linear parameters for fixed nonlinear ones q (variable projection), stacked behind q."""
        modes = np.reshape(q, (self.n_modes, 2))
        lins = [np.linalg.lstsq(_basis(t, modes, self.drift), y, rcond=None)[0] for t, y in zip(self.t, self.y)]
        return np.concatenate([q, *lins])

    def cost(self, q: tuple[float, ...]) -> float:
        """Sum of squared residuals after variable projection (the screen for starting points)."""
        return float(np.sum(self.residuals(self.linear_start(q)) ** 2))


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
        last = lag
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


def _solve(model: _JointModel, starts: list[tuple[float, ...]], lower_q, upper_q, keep: int = 5) -> PT2Fit:
    """Screen the starts by variable projection, polish the best `keep` with bounded least squares, keep the lowest
    cost, and attach the corrected covariance."""
    npar = model.nq + len(model.t) * model.nl
    lower, upper = np.full(npar, -np.inf), np.full(npar, np.inf)
    lower[: model.nq], upper[: model.nq] = lower_q, upper_q
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
    x = best.x
    resid = model.residuals(x)
    jac = model.jacobian(x)
    periods = [max(2, round(2 * np.pi / x[0] / np.median(np.diff(t)))) for t in model.t]
    cov, naive, lags = hac_covariance(jac, resid, model.blocks, periods)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    names = ("omega", "zeta", "omega2", "zeta2")
    at_bound = [
        names[i]
        for i in range(model.nq)
        if x[i] - lower[i] < 1e-6 * (upper[i] - lower[i]) or upper[i] - x[i] < 1e-6 * (upper[i] - lower[i])
    ]
    lins = model.split(x)
    fitted = model.fitted(x)
    second, second_fitted = None, ()
    if model.n_modes == 2:
        second = ModeFit(float(x[2]), float(x[3]), cov[2:4, 2:4])
        second_fitted = tuple(
            np.column_stack(_damped(t, x[2], x[3])) @ lin[_mode_cols(1, model.nl)] for t, lin in zip(model.t, lins)
        )
    return PT2Fit(
        float(x[0]),
        float(x[1]),
        cov[:2, :2],
        naive[:2, :2],
        tuple(lins),
        tuple(model.split(se)),
        tuple(fitted),
        tuple(y - f for y, f in zip(model.y, fitted)),
        tuple(lags),
        model.drift,
        tuple(at_bound),
        len(screened),
        second,
        second_fitted,
    )


def fit_pt2(
    windows: list[WindowData], omega_starts: list[float], zeta_hint: float | None = None, drift: bool = False
) -> PT2Fit:
    """Fit the free response jointly to all windows from several starts; keep the lowest cost.

    The first of omega_starts (the spectral estimate) centres the +-25 % search interval for omega."""
    model = _JointModel(windows, drift)
    omega0 = omega_starts[0]
    lo_w, hi_w = omega0 * (1 - OMEGA_SPAN), omega0 * (1 + OMEGA_SPAN)
    zetas = sorted({*ZETA_STARTS, *([float(np.clip(zeta_hint, 1e-3, 0.9))] if zeta_hint else [])})
    omegas = [float(np.clip(w * f, lo_w, hi_w)) for w in omega_starts for f in (1.0, 0.99, 1.01)]
    starts = [(w, z) for z in zetas for w in omegas]
    return _solve(model, starts, (lo_w, ZETA_BOUNDS[0]), (hi_w, ZETA_BOUNDS[1]))


def fit_two_modes(windows: list[WindowData], first: PT2Fit, omega2_start: float) -> PT2Fit:
    """Fit the main mode and a second damped mode together (second started at the PSD's secondary peak).

    Each mode's omega may move at most half-way toward the other's start, so the two cannot swap or merge; a mode
    that ends on that bound was not separated by the data."""
    model = _JointModel(windows, first.drift, n_modes=2)
    w1 = first.omega_rad_s
    half = abs(omega2_start - w1) / 2
    lower = (max(w1 - half, w1 * (1 - OMEGA_SPAN)), ZETA_BOUNDS[0], omega2_start - half, ZETA_BOUNDS[0])
    upper = (min(w1 + half, w1 * (1 + OMEGA_SPAN)), ZETA_BOUNDS[1], omega2_start + half, ZETA_BOUNDS[1])
    # the main mode starts where the single-mode fit put it; the second from the PSD peak, with several dampings
    starts = [(w1, first.zeta, omega2_start * f2, z2) for z2 in ZETA_STARTS for f2 in (1.0, 0.99, 1.01)]
    return _solve(model, starts, lower, upper, keep=3)
