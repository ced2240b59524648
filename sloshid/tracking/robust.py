"""Robust straight-line fits of edge points: least squares, drop points more than 3 MAD off, refit."""

from __future__ import annotations

import numpy as np


def robust_line(
    x: np.ndarray, y: np.ndarray, floor: float, min_points: int = 10
) -> tuple[np.ndarray, np.ndarray] | None:
    """Straight line y = slope * x + intercept through edge points, robustly: ((slope, intercept), inliers) or None
    when too few points stay.

    Each pass drops points whose residual exceeds 3 robust standard deviations (1.4826 MAD), but never
    tightens below `floor` (the measurement's own noise), so a clean edge keeps all its points. The passes only
    choose the inliers; the returned line is the least-squares fit to the final inliers, as np.polyfit's.
    """
    coef, keep = robust_lines(x, y[None, :], np.ones((1, y.size), bool), floor, min_points=min_points)
    return None if np.isnan(coef[0, 0]) else (coef[0], keep[0])


def robust_lines(
    t: np.ndarray, v: np.ndarray, ok: np.ndarray, floor: float, iterations: int = 3, min_points: int = 10
) -> tuple[np.ndarray, np.ndarray]:
    """`robust_line`'s trimmed straight lines v = slope * t + intercept, for every row of `v` at once.

    `t` (1-D, finite) is the free variable of every row; `ok` marks each row's usable points. Returns the
    (slope, intercept) per row, NaN where too few points stayed or all stood at one t, and the inlier masks. The
    rows share every array operation (the sums are matrix products): a tracker fits several edges per frame, where
    per-call overhead dominates.
    """
    centre = float(t.mean())
    tc = t - centre  # centred t: the closed form below stays well conditioned
    basis = np.stack([np.ones_like(tc), tc, tc * tc], axis=1)
    finite = ok & np.isfinite(v)
    values = np.where(finite, v, 0.0)
    dead = finite.sum(axis=1) < min_points
    keep = finite
    for passes in range(iterations + 1):
        w = keep.astype(float)
        (n, st, stt), (sv, stv) = (w @ basis).T, ((w * values) @ basis[:, :2]).T
        det = n * stt - st * st
        dead |= ~(det > 1e-12 * np.maximum(1.0, n * stt))  # all points at one t: no line through them
        slope = (n * stv - st * sv) / np.where(dead, 1.0, det)
        intercept = (sv - slope * st) / np.maximum(n, 1)
        if passes == iterations:
            break
        res = np.abs(values - intercept[:, None] - slope[:, None] * tc)
        new = finite & (res < np.maximum(3 * 1.4826 * masked_median(res, keep), floor)[:, None])
        dead |= new.sum(axis=1) < min_points
        if np.array_equal(new, keep):  # converged: further passes would repeat these fits
            break
        keep = new
    coef = np.stack([slope, intercept - slope * centre], axis=1)  # back from centred t
    coef[dead] = np.nan
    return coef, keep


def masked_median(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The median of each row of `values` over its `mask`ed entries (NaN for a row with none), by one sort."""
    count = mask.sum(axis=1)
    ordered = np.sort(np.where(mask, values, np.inf), axis=1)
    rows = np.arange(values.shape[0])
    lo, hi = ordered[rows, np.maximum(count - 1, 0) // 2], ordered[rows, np.maximum(count, 1) // 2]
    return np.where(count > 0, 0.5 * (lo + hi), np.nan)


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
