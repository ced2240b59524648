"""A prescribed path ([path] table): the user's curve, the C2 spline the planner moves along, and deviations.

The user gives either `waypoints` (passed through without stopping) or `points_csv`, a dense polyline with
columns x_m, y_m, z_m. Waypoints are joined by a cubic spline in chord length ("cubic", not-a-knot ends): C2,
so the container's acceleration along the path is continuous (a polyline would force a stop at every corner,
and a C1 curve would jump the centripetal acceleration). A CSV polyline is smoothed by a cubic smoothing spline
whose distance to every CSV point is at most `smoothing_m` (default: half of `path_tolerance_m`).

The planner needs the curve in (nearly) arc length sigma, evaluable in CasADi: the curve is resampled at equal
arc-length steps (5 cm, shorter where the tolerance needs it) and interpolated by a cubic spline in sigma, written in the truncated-power
basis p(sigma) = a0 + a1 sigma + a2 sigma^2 + a3 sigma^3 + sum_i c_i max(sigma - k_i, 0)^3 (exact for a C2 cubic
spline, and a few max() per evaluation in CasADi's SX). `max_path_deviation_m` is measured against the user's
curve (the waypoint spline, or the CSV polyline itself).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.settings import setting_field
from sloshid.core.tables import read_csv

Vec3 = tuple[float, float, float]

PIECE_M = 0.05
"""Longest spline piece of the planning curve (m); halved until the curve is within a quarter of the tolerance."""
MIN_PIECE_M = 0.005
"""Shortest spline piece (m): each piece adds a term to every evaluation of the curve in the NLP."""
REFERENCE_STEP_M = 2e-4
"""Spacing of the dense samples of the user's curve that deviations are measured against (m)."""
MIN_CSV_POINTS = 4
"""A cubic smoothing spline needs at least this many points."""
MAX_REACH_M = 5.0
"""A path point farther than this from the scenario's origin is refused: no lab arm reaches that far, and a
path given in millimetres (1000 times too large) would otherwise be splined at 0.2 mm steps over kilometres until
the memory ran out."""


@dataclass(frozen=True)
class PathTable:
    """[path]: the container's prescribed path (m), passed without stopping, at rest at both ends."""

    waypoints: list[Vec3] | None = setting_field(None, unit="m")
    """Points x, y, z (m) the path passes through, at least two, none repeated."""
    points_csv: str | None = None
    """CSV with columns x_m, y_m, z_m: a dense polyline (relative paths are relative to the scenario file)."""
    spline: Literal["cubic"] = "cubic"
    """How waypoints are joined: a C2 cubic spline in chord length (the only curve with continuous acceleration
    at constant speed among the simple choices; a polyline would need a stop at every corner)."""
    path_tolerance_m: float = setting_field(0.001, unit="m")
    """How far the container's reference point may leave the user's path (m)."""
    smoothing_m: float | None = setting_field(None, unit="m")
    """points_csv only: largest distance of the smoothed curve from any CSV point (m); default half the tolerance."""

    def __post_init__(self) -> None:
        if (self.waypoints is None) == (self.points_csv is None):
            raise UserError("[path] takes either waypoints or points_csv (one of them).")
        if not self.path_tolerance_m > 0:
            raise UserError(f"[path].path_tolerance_m must be positive (m), got {self.path_tolerance_m}.")
        if self.smoothing_m is not None and not 0 < self.smoothing_m <= self.path_tolerance_m:
            raise UserError(
                f"[path].smoothing_m must lie in (0, path_tolerance_m = {self.path_tolerance_m:g}] m, got {self.smoothing_m}."
            )
        if self.waypoints is not None:
            check_points(np.asarray(self.waypoints, dtype=float), "[path].waypoints", 2)


def check_points(points: np.ndarray, where: str, minimum: int) -> None:
    """Too few or repeated consecutive points are a UserError naming them."""
    if points.ndim != 2 or points.shape[1] != 3:
        raise UserError(f"{where} must be a list of [x, y, z] points (m).")
    if len(points) < minimum:
        raise UserError(f"{where} has {len(points)} point(s); a path needs at least {minimum}.")
    if not np.isfinite(points).all():
        raise UserError(f"{where} contains a value that is not a finite number.")
    reach = np.linalg.norm(points, axis=1)
    if reach.max() > MAX_REACH_M:
        i = int(np.argmax(reach))
        raise UserError(
            f"{where}: point {i} {[round(float(v), 6) for v in points[i]]} lies {reach[i]:g} m from the origin, "
            f"beyond any arm's reach ({MAX_REACH_M:g} m); positions are in metres (a path in millimetres is 1000 times too large)."
        )
    for i, (a, b) in enumerate(itertools.pairwise(points)):
        if math.dist(a, b) < 1e-6:
            raise UserError(f"{where}: points {i} and {i + 1} repeat {list(map(float, a))}; remove the duplicate.")


def _read_points(path: Path) -> np.ndarray:
    """The CSV polyline (n, 3)."""
    data = read_csv(path)
    missing = [c for c in ("x_m", "y_m", "z_m") if c not in data]
    if missing:
        raise UserError(f"path file {path} lacks column(s) {', '.join(missing)} (positions in m).")
    points = np.column_stack([data["x_m"], data["y_m"], data["z_m"]])
    check_points(points, f"path file {path}", MIN_CSV_POINTS)
    return points


def _chord(points: np.ndarray) -> np.ndarray:
    """Cumulative chord length of a polyline."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def _smoothed(points: np.ndarray, tol: float):
    """A cubic smoothing spline (callable of chord length) within `tol` of every point: bisection on splprep's s."""
    from scipy.interpolate import splev, splprep

    u = _chord(points)

    def fit(s: float):
        tck, _ = splprep(points.T, u=u, s=s, k=3, quiet=1)
        return tck, float(np.linalg.norm(np.array(splev(u, tck)).T - points, axis=1).max())

    lo, hi = 0.0, len(points) * tol**2
    best, err = fit(hi)
    if err > tol:
        best = fit(lo)[0]
        for _ in range(30):
            mid = (lo + hi) / 2
            tck, err = fit(mid)
            lo, hi, best = (mid, hi, tck) if err <= tol else (lo, mid, best)
    return (lambda x: np.array(splev(x, best)).T), float(u[-1])


@dataclass
class PathGeometry:
    """The planning curve p(sigma), sigma in [0, length_m], and the user's curve it stands for."""

    length_m: float
    knots: np.ndarray
    """Interior knots k_i of the truncated-power form (m of sigma)."""
    poly: np.ndarray
    """(4, 3): a0, a1, a2, a3 of the first piece."""
    jumps: np.ndarray
    """(len(knots), 3): c_i, a sixth of the jump of p''' at knot i."""
    reference: np.ndarray
    """Dense samples of the user's curve (n, 3): the waypoint spline, or the CSV polyline refined."""
    source: str = "waypoints"
    smoothing_error_m: float = 0.0
    """points_csv: largest distance of the smoothed curve from the CSV points (m)."""

    def evaluate(self, sigma: Any, order: int = 0) -> np.ndarray:
        """p (order 0) or its derivative of that order (up to 3) at sigma (n,) -> (n, 3)."""
        s = np.atleast_1d(np.asarray(sigma, dtype=float))[:, None]
        d = np.maximum(s - self.knots[None, :], 0.0)
        a0, a1, a2, a3 = self.poly
        if order == 0:
            return a0 + a1 * s + a2 * s**2 + a3 * s**3 + d**3 @ self.jumps
        if order == 1:
            return a1 + 2 * a2 * s + 3 * a3 * s**2 + 3 * d**2 @ self.jumps
        if order == 2:
            return 2 * a2 + 6 * a3 * s + 6 * d @ self.jumps
        return 6 * a3 + 6 * (d > 0).astype(float) @ self.jumps + 0 * s

    @property
    def start(self) -> np.ndarray:
        """First point (m)."""
        return self.evaluate(0.0)[0]

    @property
    def end(self) -> np.ndarray:
        """Last point (m)."""
        return self.evaluate(self.length_m)[0]

    def deviation(self, points: np.ndarray) -> np.ndarray:
        """Distance (m) of each point (n, 3) from the user's curve (nearest segment of the dense reference)."""
        from scipy.spatial import cKDTree

        ref = self.reference
        _, idx = cKDTree(ref).query(points)
        best = np.full(len(points), np.inf)
        for lo in (idx - 1, idx):  # the two segments next to the nearest sample
            a = ref[np.clip(lo, 0, len(ref) - 2)]
            b = ref[np.clip(lo, 0, len(ref) - 2) + 1]
            ab = b - a
            t = np.clip(np.einsum("ij,ij->i", points - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18), 0, 1)
            best = np.minimum(best, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
        return best


def _truncated_power(sigma: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cubic spline through points at sigma (not-a-knot) as (knots, poly (4, 3), jumps (n, 3))."""
    from scipy.interpolate import CubicSpline

    c = CubicSpline(sigma, points, bc_type="not-a-knot").c  # (4, pieces, 3), highest power first
    poly = np.array([c[3, 0], c[2, 0], c[1, 0], c[0, 0]])  # first piece about sigma = 0
    jumps = np.diff(c[0], axis=0)  # change of the cubic coefficient at each interior knot
    return sigma[1:-1].copy(), poly, jumps


def build_geometry(table: PathTable, base_dir: Path | None = None) -> PathGeometry:
    """The planning curve for a [path] table (reads and smooths points_csv)."""
    from scipy.interpolate import CubicSpline

    smoothing = 0.0
    if table.points_csv is not None:
        csv = Path(table.points_csv)
        csv = csv if csv.is_absolute() or base_dir is None else base_dir / csv
        raw = _read_points(csv)
        curve, chord_len = _smoothed(raw, table.smoothing_m or table.path_tolerance_m / 2)
        source = str(csv)
    else:
        raw = np.asarray(table.waypoints, dtype=float)
        u = _chord(raw)
        curve, chord_len = CubicSpline(u, raw, bc_type="not-a-knot"), float(u[-1])
        source = "waypoints"
    dense_u = np.linspace(0.0, chord_len, max(2000, math.ceil(chord_len / REFERENCE_STEP_M)))
    dense = curve(dense_u)
    arc = _chord(dense)
    length = float(arc[-1])
    if table.points_csv is not None:
        smoothing = float(np.linalg.norm(curve(_chord(raw)) - raw, axis=1).max())
        reference = _refine_polyline(raw)
    else:
        reference = dense
    piece = PIECE_M
    while True:  # shorter pieces until the planning curve is within a quarter of the tolerance of the user's
        sigma = np.linspace(0.0, length, max(4, math.ceil(length / piece)) + 1)
        knot_points = np.column_stack([np.interp(sigma, arc, dense[:, j]) for j in range(3)])
        geo = PathGeometry(length, *_truncated_power(sigma, knot_points), reference, source, smoothing)
        gap = geo.deviation(geo.evaluate(np.linspace(0.0, length, 2000))).max() - smoothing
        if gap <= table.path_tolerance_m / 4 or piece < MIN_PIECE_M:
            return geo
        piece /= 2


def _refine_polyline(points: np.ndarray) -> np.ndarray:
    """The polyline with extra points on long segments (its shape unchanged), for nearest-sample queries."""
    out = [points[:1]]
    for a, b in itertools.pairwise(points):
        n = max(1, math.ceil(math.dist(a, b) / REFERENCE_STEP_M))
        out.append(a + np.outer(np.arange(1, n + 1) / n, b - a))
    return np.vstack(out)


__all__ = ["PathGeometry", "PathTable", "build_geometry", "check_points"]
