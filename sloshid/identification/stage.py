"""The identification stage as one call: sources in (signal files, arrays as Signals, tracker results), an
IdentResult out. The CLI, the pipeline, the batch and `sloshid.identify` all call `identify_sources`."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.errors import warn as sloshid_warn
from sloshid.core.settings import setting_field
from sloshid.identification.estimator import Identifier, IdentResult, IdentSettings, mass_against_geometry
from sloshid.identification.signals import Signal, TracedAngles, check_csv_options, load_signal, signal_from_track

Source = str | Path | Signal | TracedAngles
"""Anything identification reads: a signal file, a Signal, or a tracker result."""

log = logging.getLogger("sloshid.identification")
"""Progress of an identification (INFO); doubts about the inputs are SloshidWarnings."""


@dataclass(frozen=True)
class SignalColumns:
    """Which columns (CSV) or variables (.mat) of a signal file hold the time in seconds and the signal; the columns
    of a tracker result's table too when every source is one (`identify_sources`)."""

    time_col: str | None = setting_field(None, metavar="NAME|INDEX")
    """CSV time column in seconds (name or 0-based index); not given: the column named t_s, time_s, t, time, times or
    timestamp, else the first."""
    value_col: str | None = setting_field(None, metavar="NAME|INDEX")
    """CSV signal column (name or 0-based index); not given: a track CSV's angle_deg, of two columns the one that is
    not the time (needed for more)."""
    time_var: str | None = setting_field(None, metavar="NAME")
    """.mat variable holding the time in seconds."""
    value_var: str | None = setting_field(None, metavar="NAME")
    """.mat variable holding the signal."""


def to_signal(source: Source, columns: SignalColumns | None = None, progress: bool = False) -> Signal:
    """One source as a Signal: files are read (with a progress bar when asked), tracker results converted without a
    file round trip (their table's columns chosen as a tracker CSV's)."""
    if isinstance(source, Signal):
        return source
    c = columns or SignalColumns()
    if isinstance(source, (str, Path)):
        return load_signal(source, c.time_col, c.value_col, c.time_var, c.value_var, progress)
    if _tracked(source):
        return signal_from_track(source, c.time_col, c.value_col)
    raise TypeError(f"cannot identify from a {type(source).__name__}; give a file path, a Signal or a TrackResult.")


MIN_SAMPLES_PER_PERIOD = 4.0
"""Samples per period of the slowest searched frequency below which no mode can be resolved (Nyquist is 2)."""


def _tracked(source: Source) -> bool:
    """A tracker result (sloshid.tracking's TrackResult), not a file or a Signal."""
    return not isinstance(source, (str, Path, Signal)) and all(hasattr(source, n) for n in ("t_s", "columns", "valid"))


def check_sampling(source: str, rate_hz: float, f_range_hz: tuple[float, float]) -> None:
    """Refuse samples (a signal's, a pose log's) too slow for the searched band, the usual sign of a time column not in
    seconds."""
    if rate_hz < MIN_SAMPLES_PER_PERIOD * f_range_hz[0]:
        lo, hi = f_range_hz
        band = f"{lo:g} Hz" if lo == hi else f"{lo:g}-{hi:g} Hz"
        # a band the user chose above plausibly timed samples (a video's 30 fps) is the band's mistake, not the clock's
        users_band = lo != hi and f_range_hz != IdentSettings().f_range_hz and rate_hz >= MIN_SAMPLES_PER_PERIOD
        cure = "the time column must be in seconds (is it in milliseconds?)"
        if users_band:
            cure = "lower `f_range_hz` below that (or, if the time column is not in seconds, convert it)"
        elif lo != hi:  # identify's search band, which the user may also lower
            cure += ", and the band below that"
        raise UserError(
            f"{source}: the samples are {1 / rate_hz:.4g} time units apart, too coarse for a mode in "
            f"{band} (at most {rate_hz / MIN_SAMPLES_PER_PERIOD:.3g} Hz at {MIN_SAMPLES_PER_PERIOD:g} samples per "
            f"period); {cure}."
        )


def past_nyquist(source: str, rate_hz: float, f_range_hz: tuple[float, float]) -> str | None:
    """The warning for a search band the user chose that reaches past the samples' Nyquist frequency (none can be found
    there), or None. The default band is cut to what the samples allow without a word: it reaches past a 30 fps
    video's."""
    if f_range_hz[1] <= 0.5 * rate_hz or f_range_hz == IdentSettings().f_range_hz:
        return None
    return (
        f"{source}: the search band reaches {f_range_hz[1]:g} Hz, past the Nyquist frequency "
        f"{0.5 * rate_hz:.3g} Hz of its samples; only the band below it is searched, and a mode above it would "
        "show there as an alias."
    )


def identify_sources(
    sources: Sequence[Source],
    settings: IdentSettings | None = None,
    columns: SignalColumns | None = None,
    warn: Callable[[str], None] | None = None,
    progress: bool = False,
) -> IdentResult:
    """Identify the sloshing mode jointly over every source (shared frequency and damping, own amplitude each).

    The same file named twice, or a copy of it, is refused: it would count its evidence twice and narrow every interval
    by sqrt(2).
    `warn` receives what the user should know about the inputs (dropped frames, uneven timestamps); `progress` shows
    bars while long files are read and fitted."""
    files = [Path(s).resolve() for s in sources if isinstance(s, (str, Path))]
    twice = sorted({str(f) for f in files if files.count(f) > 1})
    if twice:
        raise UserError(f"{twice[0]} is given more than once; each recording may count only once.")
    if not sources:
        raise UserError("nothing to identify: give at least one signal.")
    # the columns name every source's when all are tracker results; beside files they are the files' (a sensor
    # CSV's "height"), and the tracker results keep their angle
    mixed = not all(_tracked(s) for s in sources)
    named = [s for s in sources if isinstance(s, (str, Path))]
    chosen = columns or SignalColumns()
    check_csv_options(named, chosen.time_col, chosen.value_col, chosen.time_var, chosen.value_var)
    signals = [to_signal(s, SignalColumns() if mixed and _tracked(s) else columns, progress) for s in sources]
    for i, a in enumerate(signals):  # a copy under another name counts the same evidence twice as well
        for b in signals[:i]:
            if np.array_equal(a.t_s, b.t_s) and np.array_equal(a.value, b.value):
                raise UserError(f"{a.source} holds the same samples as {b.source}; each recording may count only once.")
    settings = settings or IdentSettings()
    for sig in signals:
        check_sampling(sig.source, sig.rate_hz, settings.f_range_hz)
    notes = [w for sig in signals for w in [*sig.warnings, past_nyquist(sig.source, sig.rate_hz, settings.f_range_hz)]]
    notes.append(mass_against_geometry(settings))  # also among the result's notes
    for note in filter(None, notes):
        sloshid_warn(note)
        if warn is not None:
            warn(note)
    log.info("identifying from %d signal(s): %s", len(signals), ", ".join(s.source for s in signals))
    return Identifier(settings).fit(signals, progress).result
