"""sloshid: measure liquid sloshing from video, identify its pendulum model, plan slosh-free moves.

The chain in a notebook::

    import sloshid
    tracked = sloshid.track("data/sample_tap.mp4")
    ident = sloshid.identify(tracked, mass_kg=0.5)
    result = sloshid.plan("data/scenarios/paper_1d.toml", ident)

Everything is imported lazily: `import sloshid` loads no numerics, OpenCV, CasADi, matplotlib or Dask, and changes
no global state of any of them.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

_LAZY = {
    "track": "sloshid.api",
    "inspect": "sloshid.api",
    "identify": "sloshid.api",
    "load_scenario": "sloshid.api",
    "plan": "sloshid.api",
    "compare": "sloshid.api",
    "SloshParams": "sloshid.model.pendulum",
    "TrackResult": "sloshid.tracking.tracker",
    "InspectResult": "sloshid.tracking.inspect",
    "IdentResult": "sloshid.identification.estimator",
    "PlanResult": "sloshid.planning.planner",
    "Comparison": "sloshid.comparison.compare",
    "Scenario": "sloshid.planning.scenario",
    "UserError": "sloshid.core.errors",
    # the settings classes: the command's options, the TOML tables and the functions' keywords all fill them
    "TrackSettings": "sloshid.tracking.tracker",
    "IdentSettings": "sloshid.identification.estimator",
    "SignalColumns": "sloshid.identification.stage",
    "IOSettings": "sloshid.validation.iofit",
    "GeometrySettings": "sloshid.validation.predict",
    "SynthSettings": "sloshid.synthetic.scene",
    "SolverSettings": "sloshid.planning.scenario",
    "RiskSettings": "sloshid.planning.scenario",
    "ArmSettings": "sloshid.planning.arm_settings",
    "CompareSettings": "sloshid.comparison.compare",
    "FeedbackSettings": "sloshid.comparison.feedback",
    "PlanSettings": "sloshid.planning.plan_settings",
    "PredictSettings": "sloshid.validation.predict",
    "ClusterSettings": "sloshid.core.parallel",
}
__all__ = [
    "ArmSettings",
    "ClusterSettings",
    "CompareSettings",
    "Comparison",
    "FeedbackSettings",
    "GeometrySettings",
    "IOSettings",
    "IdentResult",
    "IdentSettings",
    "InspectResult",
    "PlanResult",
    "PlanSettings",
    "PredictSettings",
    "RiskSettings",
    "Scenario",
    "SignalColumns",
    "SloshParams",
    "SolverSettings",
    "SynthSettings",
    "TrackResult",
    "TrackSettings",
    "UserError",
    "compare",
    "identify",
    "inspect",
    "load_scenario",
    "plan",
    "track",
]

if TYPE_CHECKING:
    from sloshid.api import compare, identify, inspect, load_scenario, plan, track
    from sloshid.comparison.compare import CompareSettings, Comparison
    from sloshid.comparison.feedback import FeedbackSettings
    from sloshid.core.errors import UserError
    from sloshid.core.parallel import ClusterSettings
    from sloshid.identification.estimator import IdentResult, IdentSettings
    from sloshid.identification.stage import SignalColumns
    from sloshid.model.pendulum import SloshParams
    from sloshid.planning.arm_settings import ArmSettings
    from sloshid.planning.plan_settings import PlanSettings
    from sloshid.planning.planner import PlanResult
    from sloshid.planning.scenario import RiskSettings, Scenario, SolverSettings
    from sloshid.synthetic.scene import SynthSettings
    from sloshid.tracking.inspect import InspectResult
    from sloshid.tracking.tracker import TrackResult, TrackSettings
    from sloshid.validation.iofit import IOSettings
    from sloshid.validation.predict import GeometrySettings, PredictSettings


def _installed_version() -> str:
    """The installed distribution's version (importlib.metadata scans the environment: tens of milliseconds that a
    command only spends when it writes the version)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("sloshid")
    except PackageNotFoundError:  # running from a source tree that was never installed
        return "0.0.0+unknown"


def __getattr__(name: str) -> Any:
    """Import a public name (and look up __version__) on first use (PEP 562)."""
    if name == "__version__":
        globals()[name] = _installed_version()
        return globals()[name]
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sloshid' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])
