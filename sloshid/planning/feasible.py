"""Requests no solver can meet, refused before any solve: the free planner and the upright one both check them."""

from __future__ import annotations

from sloshid.core.errors import UserError
from sloshid.planning.ocp import time_lower_bound
from sloshid.planning.scenario import Scenario, body_clearance


def check_feasible(scenario: Scenario) -> None:
    """Reject requests no solver can meet, naming the constraint at fault (UserError)."""
    lim = scenario.limits
    R = scenario.container_radius_m + scenario.solver.clearance_margin_m  # what the hard constraint keeps clear
    for i, p in enumerate(scenario.waypoints):
        label = "start" if i == 0 else "goal" if i == len(scenario.waypoints) - 1 else f"waypoint {i}"
        if not lim.z_range[0] <= p[2] <= lim.z_range[1]:
            raise UserError(
                f"the {label} {list(p)} has z = {p[2]:g} m outside [limits].z_range "
                f"[{lim.z_range[0]:g}, {lim.z_range[1]:g}] m."
            )
        for j, obstacle in enumerate(scenario.obstacles):
            if body_clearance([obstacle], p, R, scenario.container_depth_m) < 0:
                body = f", and the body {scenario.container_depth_m:g} m below it" if scenario.container_depth_m else ""
                raise UserError(
                    f"the {label} {list(p)} lies inside obstacle {j + 1} ({obstacle.describe(R)}: container "
                    f"radius plus [solver].clearance_margin_m{body}); move it out or shrink the obstacle."
                )
    for i, (a, b) in enumerate(zip(scenario.waypoints[:-1], scenario.waypoints[1:])):
        t_lb = time_lower_bound(a, b, lim, scenario.solver.kappa_T)
        if t_lb > lim.t_max_s:
            raise UserError(
                f"segment {i + 1} ({list(a)} -> {list(b)}) needs at least {t_lb:.3g} s under [limits].acc_max and "
                f"vel_max (and [solver].kappa_T), more than [limits].t_max_s = {lim.t_max_s:g} s; raise one of them."
            )
