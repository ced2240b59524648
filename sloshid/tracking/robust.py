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
    basis = np.vander(np.where(finite, x - centre, 0.0), deg + 1)
    values = np.where(finite, y, 0.0)
    for passes in range(iterations + 1):
        b = basis[keep]
        try:
            coef = np.linalg.solve(b.T @ b, b.T @ values[keep])
        except np.linalg.LinAlgError:  # all points at one x: no line through them
            return None
        if passes == iterations:
            break
        res = np.abs(values - basis @ coef)
        keep = finite & (res < max(3 * 1.4826 * median(res[keep]), floor))
        if keep.sum() < min_points:
            return None
    if deg == 1:  # the final inliers' least-squares line, back from centred x (np.polyfit's, without its SVD)
        return np.array([coef[0], coef[1] - coef[0] * centre]), keep
    return np.polyfit(x[keep], y[keep], deg), keep


def median(values: np.ndarray) -> float:
    """The median of a non-empty 1-D array by partial sorting: np.median's generality costs ten times more on the
    few hundred points of a tracker fit, several times per frame."""
    k = values.size // 2
    if values.size % 2:
        return float(np.partition(values, k)[k])
    part = np.partition(values, (k - 1, k))
    return 0.5 * float(part[k - 1] + part[k])
