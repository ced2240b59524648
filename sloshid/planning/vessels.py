"""The containers an upright move carries: one `[container]`, or a tray of `[[containers]]`, each with its rim, its
spill margin and its liquid, resolved from a Scenario into `Vessel`s (and bad trays refused in one sentence).

A container that does not tilt carries a liquid whose surface tilts by the pendulum's angle relative to it; the wall
height is R tan(angle) (`model.conventions.wall_height_mm`). The liquid may rise by the rim's height above the surface
at rest minus the spill margin, during and after the move.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from sloshid.core.errors import SMALL_FILE_BYTES, UserError, read_input
from sloshid.model.pendulum import SloshParams, cylinder_first_mode_omega
from sloshid.planning.scenario import Scenario, TrayContainer


@dataclass(frozen=True)
class Vessel:
    """One container on the tool: geometry, allowance and liquid (SI units)."""

    name: str
    radius_m: float
    """Inner radius (m)."""
    rim_m: float
    """Rim height above the liquid surface at rest (m)."""
    margin_m: float
    """Spill margin: least distance the liquid may come to the rim (m)."""
    residual_max_m: float
    """Largest wall height left swinging after arrival (m)."""
    liquid: SloshParams
    position_m: tuple[float, float] = (0.0, 0.0)
    """Centre on the tray (m)."""
    omega_sd_rad_s: float | None = None
    """Standard error of the natural frequency (from identify's JSON), None when unknown."""
    zeta_sd: float | None = None
    """Standard error of the damping ratio, None when unknown."""

    @property
    def rise_allowed_m(self) -> float:
        """How far the liquid may rise at the wall: rim minus margin (m)."""
        return self.rim_m - self.margin_m

    @property
    def angle_allowed_rad(self) -> float:
        """The surface tilt at which the wall height reaches the allowed rise."""
        return math.atan(self.rise_allowed_m / self.radius_m)

    @property
    def residual_angle_rad(self) -> float:
        """The surface tilt of the largest residual (never more than the allowed rise)."""
        return math.atan(min(self.residual_max_m, self.rise_allowed_m) / self.radius_m)


def identified_spread(path: str | Path) -> tuple[float | None, float | None]:
    """Standard errors of omega (rad/s) and zeta in an identify JSON (`parameters.<name>.stderr`), None if absent."""
    data = json.loads(read_input(path, "parameter file", SMALL_FILE_BYTES).decode("utf-8"))
    p = data.get("parameters", {}) if isinstance(data, dict) else {}

    def sd(name: str) -> float | None:
        value = p.get(name, {}).get("stderr") if isinstance(p.get(name), dict) else None
        return float(value) if isinstance(value, (int, float)) and math.isfinite(value) and value >= 0 else None

    return sd("omega_rad_s"), sd("zeta")


def _tray_liquid(c: TrayContainer, label: str, folder: Path) -> tuple[SloshParams, float | None, float | None]:
    """A tray container's liquid: its pendulum keys, its identify JSON, or its fill with a damping ratio."""
    if c.m_kg is not None and c.l_m is not None and c.d_ns_per_m is not None:
        return SloshParams(c.m_kg, c.l_m, c.d_ns_per_m), None, None
    if c.params is not None:
        path = folder / c.params
        return SloshParams.from_identify_json(path), *identified_spread(path)
    if c.fill_m is not None and c.zeta is not None:
        return SloshParams.from_modal(cylinder_first_mode_omega(c.radius_m, c.fill_m), c.zeta), None, None
    raise UserError(
        f"{label} has no known liquid: give m_kg, l_m and d_ns_per_m, params = an identify JSON, or fill_m with zeta."
    )


def _check_on_tray(scenario: Scenario, c: TrayContainer, label: str) -> None:
    """Refuse a container that does not stand wholly on the tray ([tray].size_m, centred on the tool point)."""
    if scenario.tray is None:
        return
    half = [s / 2 for s in scenario.tray.size_m]
    if any(abs(p) + c.radius_m > h + 1e-12 for p, h in zip(c.position_m, half)):
        raise UserError(
            f"{label} at ({c.position_m[0]:g}, {c.position_m[1]:g}) m with radius {c.radius_m:g} m reaches outside the "
            f"tool's tray of {scenario.tray.size_m[0]:g} x {scenario.tray.size_m[1]:g} m."
        )


def _check_margin(margin_m: float, rim_m: float, where: str) -> None:
    """Refuse a spill margin that leaves the liquid no room to rise (it would spill at rest)."""
    if margin_m >= rim_m:
        raise UserError(
            f"{where}: the spill margin of {1000 * margin_m:g} mm is not below the rim's {1000 * rim_m:g} mm above "
            "the liquid, so the liquid would break it at rest; lower [limits].spill_margin_mm or give the rim's "
            "true height."
        )


def vessels_of(scenario: Scenario, liquid: SloshParams | None, params_path: str | Path | None = None) -> list[Vessel]:
    """The scenario's containers as Vessels: its [[containers]] tray, else its one [container] with `liquid` (the
    resolved [liquid] or `--params`, whose spread `params_path` gives); UserError for what cannot be planned."""
    lim = scenario.limits
    src = scenario.source or "the scenario"
    if lim.spill_margin_mm is None:
        raise UserError(f"{src}: an upright move (tilt_max_deg = 0) needs [limits].spill_margin_mm.")
    residual = lim.residual_wall_height_max_mm / 1000
    folder = Path(scenario.source).parent if scenario.source else Path(".")
    if not scenario.containers:
        if scenario.rim_above_surface_m is None:
            raise UserError(
                f"{src}: a move within a spill margin needs [container].rim_above_surface_m (m), or [[containers]]."
            )
        if liquid is None:
            raise UserError(f"{src} has no [liquid] table; add one or give `params` (an identify JSON).")
        margin = lim.spill_margin_mm / 1000
        _check_margin(margin, scenario.rim_above_surface_m, "[container]")
        sd = identified_spread(params_path) if params_path is not None else (None, None)
        return [
            Vessel("container", scenario.container_radius_m, scenario.rim_above_surface_m, margin, residual, liquid,
                   (0.0, 0.0), *sd)
        ]  # fmt: skip
    out = []
    for i, c in enumerate(scenario.containers):
        label = f"[[containers]] #{i + 1}" + (f" ({c.name})" if c.name else "")
        _check_on_tray(scenario, c, label)
        margin = (c.spill_margin_mm if c.spill_margin_mm is not None else lim.spill_margin_mm) / 1000
        _check_margin(margin, c.rim_above_surface_m, label)
        fluid, omega_sd, zeta_sd = _tray_liquid(c, label, folder)
        name = c.name or f"container {i + 1}"
        out.append(
            Vessel(name, c.radius_m, c.rim_above_surface_m, margin, residual, fluid, c.position_m, omega_sd, zeta_sd)
        )
    return out
