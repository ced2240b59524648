"""Signals to identify: a time series with its unit and sampling facts, read from tracker CSV, any CSV or MATLAB .mat."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from sloshid.core.errors import SettingError, UserError, input_file
from sloshid.core.tables import GAP_STEP_FACTOR, read_table, refuse_video

TRACKER_COLUMNS = ("t_s", "angle_deg", "valid")
"""Columns that mark a `sloshid track` CSV; its value is `angle_deg` on rows with valid == 1."""
WHOLE_TRACKER_COLUMNS = ("frame", "t_s", "angle_smoothed_deg", "quality", "valid", "key_frame")
"""Columns of a `sloshid track` CSV that hold a value in every frame (the smoothed angle bridges the others): read
whole when chosen; any other column (the angle, the wall heights, ...) is read on rows with valid == 1 only."""

TIME_NAMES = ("t_s", "time_s", "t", "time", "times", "timestamp", "slosh_times")
"""Column/variable names taken as the time axis (seconds) when none is given."""

MAT_DEFAULTS = {"slosh_times": ("slosh_heights", "mm")}
"""Known .mat layouts: time variable -> (value variable, unit); the antisloshing runs store wall height in mm."""

UNIT_SUFFIXES = {"_deg": "deg", "_rad": "rad", "_mm": "mm", "_m": "m", "_px": "px", "_n": "N"}
"""Units read off a column name's suffix (design.md: names carry their unit)."""


MAX_BAD_FRACTION = 0.2
"""Above this fraction of NaN/inf samples a signal is refused instead of cleaned."""

MIN_SAMPLES = 16


@dataclass(frozen=True)
class Signal:
    """One measured time series (seconds, any unit) plus where it came from and how it was sampled."""

    t_s: np.ndarray
    value: np.ndarray
    label: str
    unit: str
    source: str
    n_dropped: int = 0
    """Samples dropped on reading (tracker frames with valid == 0, NaN/inf values)."""
    warnings: tuple[str, ...] = field(default=())
    """Things the user should know about the input (printed to stderr by the CLI)."""
    tracked: str = ""
    """What `sloshid track` measured in a video ('float' or 'surface'), '' for other signals: identification allows
    for the video encoder's hold in tracked signals (pt2fit.fit_pt2_hold)."""
    key_t_s: np.ndarray | None = None
    """Tracked signals: times of the video's key frames (coded without the previous pictures), where the encoder's
    hold restarts; None when unknown."""

    @property
    def rate_hz(self) -> float:
        """Nominal sampling rate: 1 / median time step."""
        return float(1.0 / np.median(np.diff(self.t_s), overwrite_input=True))  # no copy of the steps

    @property
    def jitter_s(self) -> float:
        """Timestamp jitter: standard deviation of the time steps that are not gaps."""
        dt = np.diff(self.t_s)
        mask = dt < GAP_STEP_FACTOR * np.median(dt)
        regular = dt if mask.all() else dt[mask]  # no copy when there is no gap
        return float(np.std(regular)) if regular.size else 0.0

    @property
    def n_gaps(self) -> int:
        """Number of time steps longer than 1.5 nominal steps (dropped or missing frames)."""
        dt = np.diff(self.t_s)
        return int(np.count_nonzero(dt > GAP_STEP_FACTOR * np.median(dt)))

    def sampling(self) -> dict[str, float | int]:
        """Sampling facts for reports and JSON."""
        return {
            "n_samples": int(self.t_s.size),
            "duration_s": float(self.t_s[-1] - self.t_s[0]),
            "rate_hz": self.rate_hz,
            "timestamp_jitter_s": self.jitter_s,
            "n_gaps": self.n_gaps,
            "n_dropped": self.n_dropped,
        }

    def hold_restarts(self) -> np.ndarray | None:
        """True at the samples that are the first after a key frame (the first sample starts the hold anyway)."""
        if self.key_t_s is None:
            return None
        seen = np.searchsorted(self.key_t_s, self.t_s, side="right")  # key frames at or before each sample
        return np.concatenate([[False], np.diff(seen) > 0])

    def between(self, t0: float, t1: float) -> Signal:
        """The part of the signal with t0 <= t <= t1."""
        keep = (self.t_s >= t0) & (self.t_s <= t1)
        return replace(self, t_s=self.t_s[keep], value=self.value[keep])


def make_signal(t, y, label: str, unit: str = "", source: str = "array", n_dropped: int = 0) -> Signal:
    """Validate and clean arrays into a Signal: NaN/inf dropped when few, refused when many; time must increase."""
    t = np.asarray(t, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if t.size != y.size:
        raise UserError(f"{source}: time and value have different lengths ({t.size} and {y.size}).")
    bad = ~(np.isfinite(t) & np.isfinite(y))
    notes: list[str] = []
    if bad.sum() > MAX_BAD_FRACTION * max(t.size, 1):
        why = ""
        if label == "angle_smoothed_deg" and bad.all():
            why = " (tracking with `smooth` off leaves it empty)"
        elif label.endswith("_wall_mm") and bad.all():
            why = " (tracking fills it only for `target` surface with `container_diameter_m`; _wall_px is in pixels)"
        raise UserError(
            f"{source}: {bad.sum()} of {t.size} samples of '{label}' are NaN or infinite{why}, too many to identify "
            "from."
        )
    if bad.any():
        notes.append(f"{source}: dropped {int(bad.sum())} NaN/inf samples of {t.size}.")
        t, y = t[~bad], y[~bad]
    if t.size < MIN_SAMPLES:
        raise UserError(f"{source}: only {t.size} usable samples of '{label}'; at least {MIN_SAMPLES} are needed.")
    step = np.diff(t)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0)) + 1
        raise UserError(f"{source}: time is not strictly increasing at sample {k} (t = {t[k - 1]:g} then {t[k]:g} s).")
    _check_scale(t, y, label, source)
    return Signal(t, y, label, unit, source, n_dropped + int(bad.sum()), tuple(notes))


MAX_MAGNITUDE = 1e9
"""Largest |value| or |time| taken: a billion degrees, millimetres or seconds (31 years) is no measurement, and
beyond it the fit's sums of squares overflow or lose every digit of the oscillation."""
MIN_SWING = 1e-9
"""Smallest peak-to-peak swing taken: below it the fit's scaling divides by nothing."""


def _check_scale(t: np.ndarray, y: np.ndarray, label: str, source: str) -> None:
    """Refuse a signal no fit can hold: values or times beyond MAX_MAGNITUDE, or a swing under MIN_SWING."""
    low, high = float(y.min()), float(y.max())  # no temporary array: a signal may hold ten million samples
    big = max(-low, high)
    if big > MAX_MAGNITUDE:
        raise UserError(f"{source}: '{label}' reaches {big:.3g}, no angle, wall height or position is that large.")
    if high - low < MIN_SWING:
        raise UserError(f"{source}: '{label}' is constant to {high - low:.3g} at most: nothing moved in it.")
    late = max(-float(t[0]), float(t[-1]))  # the times increase
    if late > MAX_MAGNITUDE * 1e3:  # a Unix time in seconds (1.7e9) is a logger's usual clock
        raise UserError(f"{source}: the time reaches {late:.3g} s; sloshid reads times in seconds.")


class TracedAngles(Protocol):
    """What identification needs of a tracker result (sloshid.tracking's TrackResult has it)."""

    video: Path
    t_s: np.ndarray
    valid: np.ndarray
    target: str
    key_frame: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        """The table `sloshid track` writes, by column name."""


def signal_from_track(track: TracedAngles, time_col: str | None = None, value_col: str | None = None) -> Signal:
    """A column of the tracker's table (angle_deg by default; by name or 0-based index) over time (t_s by default),
    on the valid frames unless the column holds a value in every frame: as the tracker CSV would give it, with no file
    round trip."""
    table = track.columns()
    header, where = list(table), Path(f"the track of {track.video}")
    t_i = _column_index(time_col or "t_s", header, len(header), where, "time")
    v_i = _column_index(value_col or "angle_deg", header, len(header), where, "value")
    if t_i == v_i:
        raise UserError(
            f"{where}: the time and the signal would be the same column ({header[v_i]}); choose the signal's."
        )
    label = header[v_i]
    whole = label in WHOLE_TRACKER_COLUMNS
    ok = np.ones(track.t_s.size, bool) if whole else np.asarray(track.valid).astype(bool)
    if not ok.any():
        raise UserError(
            f"{where}: no tracker frame is valid (valid == 1), so there is no measurement to identify from."
        )
    dropped = int((~ok).sum())
    t, y = np.asarray(table[header[t_i]], float), np.asarray(table[label], float)
    sig = make_signal(t[ok], y[ok], label, unit_from_name(label), str(track.video), n_dropped=dropped)
    # the key frames' times, as the CSV path reads them: for a column read on the valid frames, in the time column
    keys = None if whole else t[np.asarray(track.key_frame, bool)]
    sig = replace(sig, tracked=track.target, key_t_s=keys)
    if dropped:
        sig = replace(sig, warnings=(*sig.warnings, f"{track.video}: skipped {dropped} tracker frames with valid = 0."))
    return sig


def unit_from_name(name: str) -> str:
    """The unit a column name carries in its suffix (`angle_deg` -> `deg`), or '' when it names none."""
    lower = name.lower()
    for suffix, unit in UNIT_SUFFIXES.items():
        if lower.endswith(suffix):
            return unit
    return ""


def load_signal(
    path: str | Path,
    time_col: str | None = None,
    value_col: str | None = None,
    time_var: str | None = None,
    value_var: str | None = None,
    progress: bool = False,
) -> Signal:
    """Read one signal from a tracker CSV, a generic CSV or a MATLAB .mat file (format from suffix and columns);
    `progress` shows a bar while a long CSV is read."""
    p = input_file(path, "signal file")
    if p.suffix.lower() == ".mat":
        return _load_mat(p, time_var, value_var)
    refuse_video(
        p,
        f"{p} is a video; run `sloshid track` on it first and use the CSV it writes.",
        "a signal file sloshid reads (a `sloshid track` CSV, a CSV with a time column or a .mat file)",
    )
    return _load_csv(p, time_col, value_col, progress)


def check_csv_options(
    paths: list[str | Path],
    time_col: str | None,
    value_col: str | None,
    time_var: str | None = None,
    value_var: str | None = None,
) -> None:
    """Refuse a CSV column option when every file is a .mat file, and a .mat variable option when none is: either
    would be ignored without a word (beside a file of the other kind it chooses in the files of its own)."""
    column = "value_col" if value_col is not None else "time_col" if time_col is not None else None
    mat = [Path(p).suffix.lower() == ".mat" for p in paths]
    if column and paths and all(mat):
        raise SettingError(
            column,
            f"{{name}} chooses a CSV column, but {paths[0]} is a .mat file: its variables are chosen with {{value_var}} "
            "and {time_var}.",
            "value_var",
            "time_var",
        )
    variable = "value_var" if value_var is not None else "time_var" if time_var is not None else None
    if variable and not any(mat):
        what = f"{paths[0]} is not a .mat file" if paths else "no signal is a .mat file"
        raise SettingError(
            variable,
            f"{{name}} chooses a .mat variable, but {what}: a CSV's columns are chosen with {{value_col}} and "
            "{time_col}.",
            "value_col",
            "time_col",
        )


def _load_mat(p: Path, time_var: str | None, value_var: str | None) -> Signal:
    """Read a MATLAB v4/v5/v7 file with scipy.io.loadmat; default variables slosh_times/slosh_heights."""
    import scipy.io

    try:
        data = scipy.io.loadmat(p)
    except NotImplementedError:  # scipy's answer to a v7.3 file, which is HDF5 inside
        raise UserError(
            f"{p} is a MATLAB v7.3 (HDF5) file, which sloshid cannot read; re-save it in MATLAB with "
            "save(name, '-v7') or export the time and signal as a CSV."
        ) from None
    except Exception as exc:  # scipy raises several types for non-MAT content
        raise UserError(f"{p} is not a readable MATLAB .mat file ({type(exc).__name__}).") from None
    tname = time_var or next((n for n in TIME_NAMES if n in data), None)
    unit = ""
    if value_var is None and tname in MAT_DEFAULTS and MAT_DEFAULTS[tname][0] in data:
        value_var, unit = MAT_DEFAULTS[tname]
    tname = _mat_variable(p, data, "time", tname)
    value_var = _mat_variable(p, data, "value", value_var)
    arrays = []
    for name in (tname, value_var):
        arr = np.asarray(data[name])
        if arr.dtype.kind not in "iuf" or arr.size != max(arr.shape, default=0):
            raise UserError(f"{p}: variable '{name}' is not a numeric vector (shape {arr.shape}, type {arr.dtype}).")
        arrays.append(arr.ravel())
    return make_signal(arrays[0], arrays[1], value_var, unit or unit_from_name(value_var), str(p))


def _mat_variable(p: Path, data: dict, role: str, name: str | None) -> str:
    """The name of the .mat file's variable that holds the `role` (time or value): a refusal when none was chosen or
    the file lacks it."""
    names = sorted(k for k in data if not k.startswith("__"))
    if name is None:
        raise SettingError(
            f"{role}_var", f"{p}: say which variable holds the {role} with {{name}}; it has: {', '.join(names)}."
        )
    if name not in data:
        raise UserError(f"{p} has no variable '{name}'; it has: {', '.join(names)}.")
    return name


def _column_index(spec: str, header: list[str] | None, ncols: int, p: Path, role: str) -> int:
    """Resolve a column given by name (needs a header) or by 0-based index."""
    if header is not None and spec in header:
        return header.index(spec)
    if spec.lstrip("-").isdigit() and 0 <= int(spec) < ncols:
        return int(spec)
    available = ", ".join(header) if header else f"indices 0..{ncols - 1} (the file has no header)"
    raise UserError(f"{p} has no {role} column '{spec}'; available: {available}.")


def _load_csv(p: Path, time_col: str | None, value_col: str | None, progress: bool = False) -> Signal:
    """Read a tracker CSV (angle_deg, or the chosen column, where valid == 1) or any CSV with chosen time and value
    columns; only those columns are kept, so a long file costs little memory."""
    chosen: dict[str, int] = {}

    def pick(header: list[str] | None, ncols: int) -> list[int]:
        """The time and value columns (and a tracker CSV's valid column), resolved once the header is known."""
        is_tracker = header is not None and all(c in header for c in TRACKER_COLUMNS)
        tcol = time_col or next((n for n in TIME_NAMES if header and n in header), "0")
        vcol = value_col
        if vcol is None:
            if is_tracker:
                vcol = "angle_deg"
            elif ncols == 2:  # the column that is not the time (angle,t_s was refused as "the same column (1)")
                vcol = str(1 - _column_index(tcol, header, ncols, p, "time"))
            elif ncols == 1:
                raise UserError(
                    f"{p} has only one column; a signal file needs a time column in seconds beside the signal."
                )
            else:
                available = ", ".join(header) if header else f"indices 0..{ncols - 1}"
                raise SettingError(
                    "value_col", f"{p} has {ncols} columns; choose the signal with {{name}} (available: {available})."
                )
        chosen["t"] = _column_index(tcol, header, ncols, p, "time")
        chosen["v"] = _column_index(vcol, header, ncols, p, "value")
        if chosen["t"] == chosen["v"]:
            name = header[chosen["v"]] if header else vcol
            raise UserError(f"{p}: the time and the signal would be the same column ({name}); choose the signal's.")
        if is_tracker and header is not None and header[chosen["v"]] not in WHOLE_TRACKER_COLUMNS:
            chosen["valid"] = header.index("valid")
            if "key_frame" in header:  # written since the tracker reports key frames; older files lack it
                chosen["key"] = header.index("key_frame")
        return list(chosen.values())

    table = read_table(p, pick, progress)
    values, header = table.values, table.header or []
    del table  # the columns not kept below (valid, key_frame) are freed as soon as they are read
    t, y = values[0], values[1]
    if not t.size:
        raise UserError(f"{p} has a header but no data rows.")
    keep = values[2] == 1 if "valid" in chosen else np.ones(t.size, bool)
    dropped = int(t.size - np.count_nonzero(keep))
    if "valid" in chosen and not keep.any():
        raise UserError(f"{p}: no tracker frame is valid (valid == 1), so there is no measurement to identify from.")
    label = header[chosen["v"]] if header else f"column {chosen['v']}"
    tracked = ("surface" if "surface_angle_deg" in header else "float") if set(TRACKER_COLUMNS) <= set(header) else ""
    keys = t[values[3] == 1] if "key" in chosen else None
    del values
    if dropped:  # else the columns are taken as they are: no copy of ten million rows
        t, y = t[keep], y[keep]
    del keep
    sig = replace(
        make_signal(t, y, label, unit_from_name(label), str(p), n_dropped=dropped),
        tracked=tracked,
        key_t_s=keys,
    )
    if dropped:
        sig = replace(sig, warnings=(*sig.warnings, f"{p}: skipped {dropped} tracker frames with valid = 0."))
    return sig
