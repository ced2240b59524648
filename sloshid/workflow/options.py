"""TOML forms of the track and identify settings, shared by `sloshid run` pipelines and `sloshid batch` configs."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from sloshid.core.errors import UserError
from sloshid.core.settings import from_dict, load_toml
from sloshid.identification.estimator import IdentSettings
from sloshid.tracking.tracker import TrackSettings
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, HsvRange, preset


@dataclass(frozen=True)
class TrackOptions:
    """The [track] table: which videos and how to find the float (same meaning as `sloshid track` options)."""

    videos: list[Path] = field(default_factory=list)
    """Videos to track, relative to the pipeline file (batch takes its videos from the command line instead)."""
    float_color: str = DEFAULT_FLOAT_COLOR
    """Named float colour preset (red, orange, yellow, green, blue, magenta)."""
    float_hsv_low: tuple[int, int, int] | None = None
    """Lower OpenCV HSV corner (H 0..179, S, V 0..255); overrides float_color, needs float_hsv_high."""
    float_hsv_high: tuple[int, int, int] | None = None
    """Upper OpenCV HSV corner."""
    roi: tuple[int, int, int, int] | None = None
    """Search region x, y, width, height in pixels."""
    reference: Literal["image", "container"] = "image"
    """Angle against the image horizontal or the container's measured walls."""
    overlay: bool = False
    """Also write an overlay video per input (slower)."""
    smooth: bool = True
    """Compute the Kalman/RTS angle_smoothed_deg column."""
    target: Literal["float", "surface"] = "float"
    """What to measure: the float, or the dyed liquid's surface (its dye colour is chosen from the first frame)."""

    def __post_init__(self) -> None:
        if (self.float_hsv_low is None) != (self.float_hsv_high is None):
            raise UserError("[track] needs float_hsv_low and float_hsv_high together.")
        self.track_settings()  # validate colour and ROI now, before anything runs

    def track_settings(self) -> TrackSettings:
        """The tracker's own settings object."""
        hsv = (
            HsvRange(self.float_hsv_low, self.float_hsv_high)
            if self.float_hsv_low is not None
            else preset(self.float_color).hsv
        )
        return TrackSettings(hsv=hsv, roi=self.roi, reference=self.reference, smooth=self.smooth, target=self.target)


@dataclass(frozen=True)
class IdentifyOptions(IdentSettings):
    """The [identify] table: the identification settings plus signal files other than tracked videos."""

    signals: list[Path] = field(default_factory=list)
    """Extra signal files (tracker CSV, CSV, .mat) relative to the pipeline file; tracked videos are added."""
    time_col: str | None = None
    """CSV time column (seconds) for `signals`."""
    value_col: str | None = None
    """CSV value column for `signals`."""
    time_var: str | None = None
    """.mat time variable for `signals`."""
    value_var: str | None = None
    """.mat value variable for `signals`."""

    def ident_settings(self) -> IdentSettings:
        """The identifier's own settings object."""
        return IdentSettings(**{f.name: getattr(self, f.name) for f in dataclasses.fields(IdentSettings)})

    def load_options(self) -> dict[str, Any]:
        """Keyword arguments for sloshid.identification.signals.load_signal."""
        return {k: getattr(self, k) for k in ("time_col", "value_col", "time_var", "value_var")}


@dataclass(frozen=True)
class BatchConfig:
    """A `sloshid batch --config` file: a [track] table and an optional [identify] table."""

    track: TrackOptions
    identify: IdentifyOptions

    @classmethod
    def load(cls, path: str | Path) -> BatchConfig:
        """Read and validate; videos come from the command line, so `videos`/`signals` are refused here."""
        raw = load_toml(path)
        for key in raw:
            if key not in ("track", "identify"):
                raise UserError(f"{path}: unknown section [{key}]; a batch config has [track] and [identify].")
        track = from_dict(TrackOptions, raw.get("track", {}), "[track]")
        ident = from_dict(IdentifyOptions, raw.get("identify", {}), "[identify]")
        if track.videos or ident.signals:
            raise UserError(
                f"{path}: a batch takes its videos from the command line; remove [track].videos and [identify].signals."
            )
        return cls(track, ident)
