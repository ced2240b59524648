"""An estimate with its 95 % interval: the one place a fitted parameter's interval is formed (cut at the parameter's
bounds) and written with the digits its error allows."""

from __future__ import annotations

import math
from dataclasses import dataclass

from sloshid.identification.pt2fit import Z95


@dataclass(frozen=True)
class Estimate:
    """A value with its standard error and 95 % interval."""

    value: float
    stderr: float
    ci95: tuple[float, float]
    bounds: tuple[float, float] = (-math.inf, math.inf)
    """The parameter's range (its search bounds or physical range): the interval ends there at the most."""

    def to_dict(self) -> dict:
        """{"value", "stderr", "ci95": [lo, hi]}, and "bounds": [lo, hi] (null: open) for a bounded parameter."""
        out: dict = {"value": self.value, "stderr": self.stderr, "ci95": list(self.ci95)}
        if any(math.isfinite(b) for b in self.bounds):
            out["bounds"] = [b if math.isfinite(b) else None for b in self.bounds]
        return out

    def shown(self, x: float | None = None) -> str:
        """The value (or `x`, e.g. an interval bound) as `shown_with_error` writes it."""
        return shown_with_error(self.value if x is None else x, self.stderr)

    def interval_ends(self) -> tuple[str, str]:
        """The 95 % interval's ends as `interval_ends` writes them."""
        return interval_ends(self.ci95, self.stderr, self.bounds)

    def interval(self) -> str:
        """'LO .. HI', an end cut at the parameter's bound saying so."""
        return " .. ".join(self.interval_ends())


def interval_ends(ci95, stderr: float | None, bounds=None) -> tuple[str, str]:
    """An interval's ends with the digits their error allows (`shown_with_error`), an end that lies on the parameter's
    bound (`bounds`, None or null for open) marked "(its bound)": the normal interval was cut there."""
    lo, hi = (
        shown_with_error(end, stderr) + (" (its bound)" if bound is not None and end == bound else "")
        for end, bound in zip(ci95, bounds or (None, None))
    )
    return lo, hi


def shown_with_error(x: float, stderr: float | None) -> str:
    """`x` with digits down to the standard error's second significant one, at least 5: f = 1.9996 +- 0.0002 Hz must
    not read 2."""
    digits = 5
    if x != 0 and math.isfinite(x) and stderr and stderr > 0 and math.isfinite(stderr):
        digits = max(5, math.floor(math.log10(abs(x))) - math.floor(math.log10(stderr)) + 2)
    return f"{x:.{min(digits, 12)}g}"


def estimate(value: float, se: float, bounds: tuple[float, float] = (-math.inf, math.inf)) -> Estimate:
    """Normal 95 % interval, cut at the parameter's `bounds` (its search bounds or physical range; 0 for quantities
    that cannot be negative): a value the fit could not reach is no part of it."""
    lo, hi = max(value - Z95 * se, bounds[0]), min(value + Z95 * se, bounds[1])
    return Estimate(float(value), float(se), (float(lo), float(hi)), (float(bounds[0]), float(bounds[1])))
