"""The settings of one plan beside its scenario: which variant to plan and what to draw besides it (`sloshid plan`'s
options; `sloshid.plan`'s `robust` keyword)."""

from __future__ import annotations

from dataclasses import dataclass

from sloshid.core.errors import SettingError
from sloshid.core.settings import setting_field

MAX_SWEEP_MARGINS = 50
"""Most spill margins a margin sweep plans at: each is a plan of its own."""


@dataclass(frozen=True)
class PlanSettings:
    """How a scenario is planned: the nominal or the robust variant, and an optional spill-margin sweep."""

    robust: bool = False
    """Plan the robust variant, the one `sloshid compare` scores as 'sloshid robust plan': the liquid at every
    frequency factor of the scenario's [compare] robust_omega_factors (default 0.9, 1.0, 1.1) ends at rest (a move
    within a spill margin: the margin holds for the sampled models of [risk].scenarios, or 50)."""
    sweep_margin: tuple[float, float, int] | None = setting_field(
        None, unit="mm", metavar="MIN:MAX:COUNT", separator=":"
    )
    """Moves within a spill margin (upright, or tilting on a straight [move]): also plan at COUNT spill margins from
    MIN to MAX and draw transfer time and risk against the margin in OUTPUT_margin_sweep.png beside the trajectory
    CSV."""

    def __post_init__(self) -> None:
        if self.sweep_margin is not None:
            lo, hi, count = self.sweep_margin
            if not (0 <= lo < hi and 2 <= count <= MAX_SWEEP_MARGINS):
                raise SettingError(
                    "sweep_margin",
                    f"{{name}} needs 0 <= MIN < MAX (mm) and a COUNT of 2 to {MAX_SWEEP_MARGINS}, got "
                    f"{lo:g}:{hi:g}:{count}.",
                )

    def margins_mm(self) -> list[float]:
        """The spill margins of the sweep (mm), MIN to MAX in COUNT steps; empty without one."""
        import numpy as np

        if self.sweep_margin is None:
            return []
        lo, hi, count = self.sweep_margin
        return [float(v) for v in np.linspace(lo, hi, count)]
