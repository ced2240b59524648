"""Robust polynomial fits of edge points: least squares, drop points more than 3 MAD off, refit."""

from __future__ import annotations

import numpy as np


def robust_polyfit(
    x: np.ndarray, y: np.ndarray, deg: int, floor: float, iterations: int = 3, min_points: int = 10
) -> tuple[np.ndarray, np.ndarray] | None:
    """Polynomial coefficients (highest power first) and the inlier mask, or None when too few points stay.

    Each pass drops points whose residual exceeds 3 robust standard deviations (1.4826 MAD), but never
    tightens below `floor` (the measurement's own noise), so a clean edge keeps all its points. The passes only
    choose the inliers, with the normal equations on centred x (microseconds; the tracker fits several lines per
    frame); the returned coefficients are the least-squares fit to the final inliers, as np.polyfit's.
    """
    finite = np.isfinite(x) & np.isfinite(y)
    keep = finite
    if keep.sum() < min_points:
        return None
    centre = np.mean(x[finite])
    xc = np.where(finite, x - centre, 0.0)
    values = np.where(finite, y, 0.0)
    basis = None if deg == 1 else np.vander(xc, deg + 1)
    for passes in range(iterations + 1):
        coef = _line(xc[keep], values[keep]) if basis is None else normal_solve(basis[keep], values[keep])
        if coef is None:  # all points at one x: no line through them
            return None
        if passes == iterations:
            break
        res = np.abs(values - (coef[0] * xc + coef[1] if basis is None else basis @ coef))
        new = finite & (res < max(3 * 1.4826 * median(res[keep]), floor))
        if new.sum() < min_points:
            return None
        if np.array_equal(new, keep):  # converged: further passes would repeat this fit
            break
        keep = new
    if deg == 1:  # the final inliers' least-squares line, back from centred x (np.polyfit's, without its SVD)
        return np.array([coef[0], coef[1] - coef[0] * centre]), keep
    return np.polyfit(x[keep], y[keep], deg), keep


def _line(x: np.ndarray, y: np.ndarray) -> np.ndarray | None:
    """Least-squares (slope, intercept) of y on centred x in closed form: a tenth of a general solve's overhead."""
    n, sx, sy = x.size, x.sum(), y.sum()
    det = n * (x @ x) - sx * sx
    if not det > 1e-12 * max(1.0, n * (x @ x)):
        return None
    slope = (n * (x @ y) - sx * sy) / det
    return np.array([slope, (sy - slope * sx) / n])


def normal_solve(basis: np.ndarray, y: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray | None:
    """Least-squares coefficients by the normal equations (over the `rows` mask when given), or None when the basis
    is singular. The mask weights the sums instead of copying the rows: the robust fits call this every pass."""
    bt = basis.T if rows is None else basis.T * rows
    try:
        return np.linalg.solve(bt @ basis, bt @ y)
    except np.linalg.LinAlgError:
        return None


def median(values: np.ndarray) -> float:
    """The median of a non-empty 1-D array by partial sorting: np.median's generality costs ten times more on the
    few hundred points of a tracker fit, several times per frame."""
    k = values.size // 2
    if values.size % 2:
        return float(np.partition(values, k)[k])
    part = np.partition(values, (k - 1, k))
    return 0.5 * float(part[k - 1] + part[k])
