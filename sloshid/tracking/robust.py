"""Robust polynomial fits of edge points: least squares, drop points more than 3 MAD off, refit."""

from __future__ import annotations

import numpy as np


def robust_polyfit(
    x: np.ndarray, y: np.ndarray, deg: int, floor: float, iterations: int = 3, min_points: int = 10
) -> tuple[np.ndarray, np.ndarray] | None:
    """Polynomial coefficients (highest power first) and the inlier mask, or None when too few points stay.

    Each pass drops points whose residual exceeds 3 robust standard deviations (1.4826 MAD), but never
    tightens below `floor` (the measurement's own noise), so a clean edge keeps all its points.
    """
    keep = np.isfinite(x) & np.isfinite(y)
    if keep.sum() < min_points:
        return None
    for _ in range(iterations):
        coef = np.polyfit(x[keep], y[keep], deg)
        res = y - np.polyval(coef, x)
        mad = 1.4826 * np.median(np.abs(res[keep]))
        keep = np.isfinite(res) & (np.abs(res) < max(3 * mad, floor))
        if keep.sum() < min_points:
            return None
    return np.polyfit(x[keep], y[keep], deg), keep
