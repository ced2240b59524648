"""TOML forms of the track and identify settings, shared by `sloshid run` pipelines and `sloshid batch` configs."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from sloshid.core.errors import SettingError, UserError
from sloshid.core.settings import from_dict, load_toml
from sloshid.identification.estimator import IdentSettings
from sloshid.identification.stage import SignalColumns
from sloshid.tracking.tracker import SURFACE_COLUMNS, TRACK_COLUMNS, TrackSettings


@dataclass(frozen=True)
class TrackOptions(TrackSettings):
    """The [track] table: the tracker's settings plus which videos and whether to write overlays."""

    videos: list[Path] = field(default_factory=list)
    """Videos to track, relative to the pipeline file (batch takes its videos from the command line instead)."""
    overlay: bool = False
    """Also write an overlay video per input (slower)."""

    def track_settings(self) -> TrackSettings:
        """The tracker's own settings object."""
        return TrackSettings(**{f.name: getattr(self, f.name) for f in dataclasses.fields(TrackSettings)})


@dataclass(frozen=True)
class IdentifyOptions(IdentSettings):
    """The [identify] table: the identification settings plus signal files other than tracked videos."""

    signals: list[Path] = field(default_factory=list)
    """Extra signal files (tracker CSV, CSV, .mat) relative to the pipeline file; tracked videos are added."""
    time_col: str | None = None
    """CSV time column (seconds), by name or 0-based index, of `signals`; without signals, of the tracked tables."""
    value_col: str | None = None
    """CSV value column of `signals`; without signals, of the tracked videos' tables (`sloshid batch` too)."""
    time_var: str | None = None
    """.mat time variable for `signals`."""
    value_var: str | None = None
    """.mat value variable for `signals`."""

    def ident_settings(self) -> IdentSettings:
        """The identifier's own settings object."""
        return IdentSettings(**{f.name: getattr(self, f.name) for f in dataclasses.fields(IdentSettings)})

    def columns(self) -> SignalColumns:
        """Which columns or variables of the sources to read (.mat variables: of the `signals` files)."""
        return SignalColumns(self.time_col, self.value_col, self.time_var, self.value_var)


def check_tracked_columns(track: TrackOptions, ident: IdentifyOptions) -> None:
    """An [identify] that reads the tracked tables (no `signals` of its own) names columns they have: a misspelt or
    other-target `value_col` was found only after every video was tracked, in a hidden cache file's name."""
    if ident.signals:
        return
    columns = SURFACE_COLUMNS if track.target == "surface" else TRACK_COLUMNS
    # the millimetre columns are there but empty without the container's scale
    usable = [c for c in columns if track.container_diameter_m is not None or not c.endswith("_mm")]
    chosen = {}
    for key in ("time_col", "value_col"):
        name = getattr(ident, key)
        if name is None:
            continue
        index = int(name) if name.isdigit() else None  # as the reader takes an index
        chosen[key] = columns[index] if index is not None and index < len(columns) else name
        if chosen[key] not in usable:
            empty = chosen[key] in columns  # a millimetre column without the scale
            raise SettingError(
                key,
                f"{{name}} '{name}' is "
                + ("empty in" if empty else "not a column of")
                + f" the tracked tables (target {track.target}"
                + (": give [track].container_diameter_m for the millimetres" if empty else "")
                + f"); they have {', '.join(usable)}.",
            )
    if chosen.get("value_col", "") == chosen.get("time_col", "t_s"):
        raise SettingError("value_col", f"{{name}} '{ident.value_col}' is the tracked tables' time column.")


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
        try:
            check_tracked_columns(track, ident)
        except SettingError as exc:
            raise UserError(str(exc.named(lambda setting: f"{path}: [identify].{setting}"))) from None
        return cls(track, ident)
