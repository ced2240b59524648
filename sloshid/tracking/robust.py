"""Robust straight-line fits of edge points: least squares, drop points more than 3 MAD off, refit."""

from __future__ import annotations

import numpy as np

MAD_SIGMA = 1.4826
"""Standard deviations per median absolute deviation of normally distributed residuals: a robust scale."""


def robust_lines(
    t: np.ndarray,
    v: np.ndarray,
    ok: np.ndarray,
    floor: float,
    iterations: int = 3,
    min_points: int | np.ndarray = 10,
) -> tuple[np.ndarray, np.ndarray]:
    """Robust straight lines v = slope * t + intercept through edge points, for every row of `v` at once.

    Each pass drops points whose residual exceeds 3 robust standard deviations (1.4826 MAD), but never tightens
    below `floor` (the measurement's own noise), so a clean edge keeps all its points. The passes only choose the
    inliers; each line is the least-squares fit to its final inliers, as np.polyfit's. `t` (finite; one row for
    all, or one per row of `v`) is the free variable; `ok` marks each row's usable points (rows of different lengths
    are padded). Returns the (slope, intercept) per row, NaN where fewer than `min_points` (per row, or one for all)
    stayed or all stood at one t, and the inlier masks. The rows share every array operation: a tracker fits several
    edges per frame, where per-call overhead dominates.
    """
    t = np.broadcast_to(t, v.shape)
    finite = ok & np.isfinite(v)
    count = finite.sum(axis=1)
    centre = np.where(finite, t, 0.0).sum(axis=1) / np.maximum(count, 1)
    tc = t - centre[:, None]  # centred on the usable points: the closed form below stays well conditioned
    values = np.where(finite, v, 0.0)
    keep, alive = finite, count >= min_points
    for passes in range(iterations + 1):
        w = keep.astype(float)
        wt = w * tc
        n, st, stt = w.sum(axis=1), wt.sum(axis=1), (wt * tc).sum(axis=1)
        sv, stv = (w * values).sum(axis=1), (wt * values).sum(axis=1)
        det = n * stt - st * st
        alive &= det > 1e-12 * np.maximum(n * stt, 1.0)  # all points at one t: no line
        slope = (n * stv - st * sv) / np.where(alive, det, 1.0)
        intercept = (sv - slope * st) / np.maximum(n, 1.0)
        if passes == iterations:
            break
        res = np.abs(values - intercept[:, None] - slope[:, None] * tc)
        new = finite & (res < np.maximum(3 * MAD_SIGMA * masked_median(res, keep), floor)[:, None])
        alive &= new.sum(axis=1) >= min_points  # a row once short of points stays without a line
        new[~alive] = keep[~alive]
        if not (new ^ keep).any():  # converged: further passes would repeat these fits
            break
        keep = new
    coef = np.empty((v.shape[0], 2))
    coef[:, 0], coef[:, 1] = slope, intercept - slope * centre  # back from centred t
    coef[~alive] = np.nan
    return coef, keep


def straight_part(t: np.ndarray, v: np.ndarray, ok: np.ndarray, tol: float, max_slope: float) -> np.ndarray:
    """The usable points (`ok`) of each row of `v` (over `t`, one row for all) within `tol` of the straight line that
    most of them lie on, among lines through two points at least a quarter of the row's span apart, each the median
    of five neighbours, and steeper in `t` than `max_slope` nowhere: a wall's edge points are one long straight run,
    while a curved bottom, a sloped surface or a holder below take a minority or a shorter run of rows. Rows with
    fewer than ten usable points keep them all (the line fit's own minimum decides)."""
    keep = ok.copy()
    for k in range(v.shape[0]):
        at = np.flatnonzero(ok[k])
        if at.size < 10:
            continue
        pos = np.linspace(2, at.size - 3, min(12, at.size - 4)).astype(int)  # anchors, among the usable points
        ta = t[at[pos]].astype(float)
        va = np.partition(v[k, at[pos[:, None] + np.arange(-2, 3)]], 2, axis=1)[:, 2]  # medians of five
        i, j = np.triu_indices(len(pos), 1)
        far = np.abs(ta[j] - ta[i]) >= 0.25 * (t[at[-1]] - t[at[0]])
        i, j = i[far], j[far]
        if i.size == 0:
            continue
        slope = (va[j] - va[i]) / (ta[j] - ta[i])
        fine = np.abs(slope) <= max_slope
        if not fine.any():
            continue
        i, j, slope = i[fine], j[fine], slope[fine]
        res = np.abs(v[k, at][None, :] - (va[i, None] + slope[:, None] * (t[at][None, :] - ta[i, None])))
        best = int(np.argmax((res <= tol).sum(axis=1)))
        keep[k] = False
        keep[k, at[res[best] <= tol]] = True
    return keep


def masked_median(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The median of each row of `values` over its `mask`ed entries (NaN for a row with none), by one sort; the
    masked entries must not be NaN."""
    count = np.count_nonzero(mask, axis=1)
    ordered = np.sort(np.where(mask, values, np.inf), axis=1).ravel()
    first = np.arange(0, ordered.size, values.shape[1])
    median = 0.5 * (ordered[first + np.maximum(count - 1, 0) // 2] + ordered[first + count // 2 - (count == 0)])
    median[count == 0] = np.nan
    return median


def normal_solve(
    basis: np.ndarray, y: np.ndarray, rows: np.ndarray | None = None, ridge: np.ndarray | None = None
) -> np.ndarray | None:
    """Least-squares coefficients by the normal equations (over the `rows` mask when given), or None when the basis
    is singular. The mask weights the sums instead of copying the rows: the robust fits call this every pass.
    `ridge` is added to the normal matrix's diagonal: a zero-mean prior on each coefficient (noise over prior
    variance)."""
    bt = basis.T if rows is None else basis.T * rows
    normal = bt @ basis if ridge is None else bt @ basis + np.diag(ridge)
    try:
        return np.linalg.solve(normal, bt @ y)
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


def scatter(values: np.ndarray) -> float:
    """The robust standard deviation of a non-empty 1-D array about its median (MAD_SIGMA median absolute deviations)."""
    return MAD_SIGMA * median(np.abs(values - median(values)))


def running_median(values: np.ndarray, size: int) -> np.ndarray:
    """The medians of every `size` consecutive values (the upper middle one for an even `size`), len - size + 1 of them."""
    return np.sort(np.lib.stride_tricks.sliding_window_view(values, size), axis=1)[:, size // 2]


def percentile_span(values: np.ndarray) -> float:
    """The span from the 1st to the 99th percentile of the finite values (0.0 for none), by one sort: np.percentile
    would import numpy.ma at the end of every tracking run."""
    v = np.sort(values[np.isfinite(values)])
    return float(v[int(0.99 * (v.size - 1))] - v[int(0.01 * (v.size - 1))]) if v.size else 0.0
