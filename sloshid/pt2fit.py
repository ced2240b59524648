"""Least-squares fit of a damped PT2 free response to one or several windows (shared omega and zeta).

Model per window (t' = t - window start):  y = exp(-zeta omega t') (a cos(omega_d t') + b sin(omega_d t')) + c [+ r t'],
omega_d = omega sqrt(1 - zeta^2). Standard errors come from a Newey-West (Bartlett kernel) sandwich covariance,
which stays honest when residuals are serially correlated (video tracking noise, unmodelled harmonics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

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
class PT2Fit:
    """Result of the (joint) PT2 fit with its corrected covariance."""

    omega_rad_s: float
    zeta: float
    cov: np.ndarray
    """2x2 covariance of (omega, zeta), Newey-West corrected."""
    cov_naive: np.ndarray
    """2x2 covariance assuming white residuals (s^2 (J'J)^-1), kept to show how much the correction widened it."""
    linear: tuple[np.ndarray, ...]
    """Per window: (a, b, c[, r])."""
    linear_se: tuple[np.ndarray, ...]
    fitted: tuple[np.ndarray, ...]
    residuals: tuple[np.ndarray, ...]
    hac_lags: tuple[int, ...]
    drift: bool
    at_bound: tuple[str, ...]
    """Names of parameters that ended on a search bound."""
    n_starts: int

    def fit_percent(self, i: int, values: np.ndarray) -> float:
        """NRMSE fit in percent (100 = perfect, 0 = no better than the mean) of window i."""
        return nrmse_fit_percent(values, self.fitted[i])

    def amplitude(self, i: int) -> float:
        """Oscillation amplitude at the start of window i (value unit)."""
        a, b = self.linear[i][:2]
        return float(np.hypot(a, b))

    def amplitude_se(self, i: int) -> float:
        """Standard error of that amplitude (delta method, a and b treated as independent)."""
        a, b = self.linear[i][:2]
        sa, sb = self.linear_se[i][:2]
        amp = np.hypot(a, b)
        return float(np.sqrt((a * sa) ** 2 + (b * sb) ** 2) / amp) if amp > 0 else float("inf")


def nrmse_fit_percent(y: np.ndarray, yhat: np.ndarray) -> float:
    """100 (1 - |y - yhat| / |y - mean(y)|), the system-identification 'fit %'."""
    denom = np.linalg.norm(y - np.mean(y))
    return float(100 * (1 - np.linalg.norm(y - yhat) / denom)) if denom > 0 else float("-inf")


def free_response(t_rel: np.ndarray, omega: float, zeta: float, lin: np.ndarray) -> np.ndarray:
    """The damped free response with linear parameters lin = (a, b, c[, r])."""
    sigma, wd = zeta * omega, omega * np.sqrt(1 - zeta * zeta)
    e = np.exp(-sigma * t_rel)
    y = e * (lin[0] * np.cos(wd * t_rel) + lin[1] * np.sin(wd * t_rel)) + lin[2]
    return y + lin[3] * t_rel if len(lin) > 3 else y


def _basis(t_rel: np.ndarray, omega: float, zeta: float, drift: bool) -> np.ndarray:
    """Columns multiplying the linear parameters (a, b, c[, r]) for given omega, zeta."""
    sigma, wd = zeta * omega, omega * np.sqrt(1 - zeta * zeta)
    e = np.exp(-sigma * t_rel)
    cols = [e * np.cos(wd * t_rel), e * np.sin(wd * t_rel), np.ones_like(t_rel)]
    if drift:
        cols.append(t_rel)
    return np.column_stack(cols)


class _JointModel:
    """Residuals and analytic Jacobian of the stacked windows for x = (omega, zeta, lin_1, ..., lin_K)."""

    def __init__(self, windows: list[WindowData], drift: bool):
        self.t = [w.t_s - w.t0_s for w in windows]
        self.y = [w.value for w in windows]
        self.nl = 4 if drift else 3
        self.drift = drift
        ends = np.cumsum([0] + [t.size for t in self.t])
        self.blocks = [slice(a, b) for a, b in zip(ends[:-1], ends[1:])]
        """Rows of each window in the stacked residual vector."""

    def split(self, x: np.ndarray) -> list[np.ndarray]:
        """Per-window linear parameters from the stacked vector."""
        return [x[2 + k * self.nl : 2 + (k + 1) * self.nl] for k in range(len(self.t))]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Model minus data, all windows stacked."""
        return np.concatenate([free_response(t, x[0], x[1], lin) - y for t, y, lin in zip(self.t, self.y, self.split(x))])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d residuals / d x, analytic."""
        omega, zeta = x[0], x[1]
        root = np.sqrt(max(1 - zeta * zeta, 1e-12))
        sigma, wd = zeta * omega, omega * root
        jac = np.zeros((self.blocks[-1].stop, x.size))
        for k, (t, lin, rows) in enumerate(zip(self.t, self.split(x), self.blocks)):
            e = np.exp(-sigma * t)
            c, s = np.cos(wd * t), np.sin(wd * t)
            osc = e * (lin[0] * c + lin[1] * s)
            d_sigma = -t * osc
            d_wd = e * t * (-lin[0] * s + lin[1] * c)
            jac[rows, 0] = d_sigma * zeta + d_wd * root
            jac[rows, 1] = d_sigma * omega - d_wd * omega * zeta / root
            jac[rows, 2 + k * self.nl : 2 + (k + 1) * self.nl] = _basis(t, omega, zeta, self.drift)
        return jac

    def linear_start(self, omega: float, zeta: float) -> np.ndarray:
        """Best linear parameters for fixed omega, zeta (variable projection), stacked behind omega, zeta."""
        lins = [np.linalg.lstsq(_basis(t, omega, zeta, self.drift), y, rcond=None)[0] for t, y in zip(self.t, self.y)]
        return np.concatenate([[omega, zeta], *lins])


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
    a = np.linalg.lstsq(g[:-1], g[1:], rcond=None)[0].T
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
    npar = 2 + len(windows) * model.nl
    lower = np.full(npar, -np.inf)
    upper = np.full(npar, np.inf)
    lower[:2] = (lo_w, ZETA_BOUNDS[0])
    upper[:2] = (hi_w, ZETA_BOUNDS[1])
    # a cheap variable-projection screen picks the most promising starts before the full solves
    screened = sorted(starts, key=lambda s: np.sum(model.residuals(model.linear_start(*s)) ** 2))[:5]
    best = None
    for omega_s, zeta_s in screened:
        x0 = model.linear_start(omega_s, zeta_s)
        res = optimize.least_squares(
            model.residuals, x0, jac=model.jacobian, bounds=(lower, upper), x_scale="jac", method="trf", tr_solver="lsmr",
            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200,
        )
        if best is None or res.cost < best.cost:
            best = res
    x = best.x
    resid = model.residuals(x)
    jac = model.jacobian(x)
    periods = [max(2, int(round(2 * np.pi / x[0] / np.median(np.diff(t))))) for t in model.t]
    cov, naive, lags = hac_covariance(jac, resid, model.blocks, periods)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    at_bound = []
    for name, i in (("omega", 0), ("zeta", 1)):
        span = upper[i] - lower[i]
        if x[i] - lower[i] < 1e-6 * span or upper[i] - x[i] < 1e-6 * span:
            at_bound.append(name)
    lins = model.split(x)
    ses = model.split(se)
    fitted = [free_response(t, x[0], x[1], lin) for t, lin in zip(model.t, lins)]
    return PT2Fit(
        float(x[0]), float(x[1]), cov[:2, :2], naive[:2, :2], tuple(lins), tuple(ses), tuple(fitted),
        tuple(y - f for y, f in zip(model.y, fitted)), tuple(lags), drift, tuple(at_bound), len(screened),
    )
