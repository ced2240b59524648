"""Column tables as CSV: the contract between stages is the column names (with units), so keep I/O in one place."""

from __future__ import annotations

import csv
import itertools
import math
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from tqdm import tqdm

from sloshid.core.atomic import write_text
from sloshid.core.errors import UserError, input_file, open_input


def distinct_names(paths: Sequence[str | os.PathLike]) -> list[str]:
    """How a table names each file: its file name, or, where two share one (d1/x.mp4, d2/x.mp4; batch folders'
    angles.csv), its path below the folder all the files are in."""
    names = [Path(p).name for p in paths]
    if len(set(names)) == len(names):
        return names
    common = Path(os.path.commonpath([str(Path(p).resolve().parent) for p in paths]))
    return [str(Path(p).resolve().relative_to(common)) if names.count(n) > 1 else n for p, n in zip(paths, names)]


def table_to_csv(columns: dict[str, np.ndarray], digits: int = 9) -> str:
    """CSV text of equally long columns: whole numbers without decimals, floats with `digits` significant digits (no
    "-0"), and the time column `t_s` in the shortest form that reads back to the same bits: analyses compare timestamps
    exactly (key frames, window ends), so `identify` of a written track CSV equals `identify` of the TrackResult it came
    from."""
    names = list(columns)
    # adding 0.0 turns a negative zero (a product of a zero and a negative number) into 0, every other value unchanged
    cols = [np.asarray(columns[n]) for n in names]
    cols = [c + 0.0 if np.issubdtype(c.dtype, np.floating) else c for c in cols]
    fmt = [
        "%d".__mod__
        if np.issubdtype(c.dtype, np.integer) or c.dtype == bool
        else _exact
        if n == "t_s"
        else f"%.{digits}g".__mod__
        for n, c in zip(names, cols)
    ]
    lines = [",".join(names)]
    lines.extend(",".join(f(v) for f, v in zip(fmt, row)) for row in zip(*cols))
    return "\n".join(lines) + "\n"


def _exact(value: float) -> str:
    """The shortest decimal that reads back as this float (Python's repr of it)."""
    return repr(float(value))


def write_csv(path: str | Path, columns: dict[str, np.ndarray], digits: int = 9) -> None:
    """Write columns to `path` atomically (floats with `digits` significant digits)."""
    write_text(path, table_to_csv(columns, digits))


def read_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a numeric CSV with a header (as write_csv writes it) into float columns keyed by header name."""
    p = input_file(path, "table")
    table = read_table(p)
    if table.header is None:
        raise UserError(f"{p} has no header row naming its columns.")
    return dict(zip(table.header, table.values))


def to_pandas(columns: dict[str, Any]):
    """A pandas DataFrame of equal-length columns (pandas is optional: `pip install sloshid[pandas]`)."""
    try:
        import pandas as pd
    except ImportError:
        raise UserError("to_pandas() needs pandas; install it with `pip install pandas`.") from None
    return pd.DataFrame(columns)


GAP_STEP_FACTOR = 1.5
"""A time step longer than this many median steps is a gap (lost frames, dropped samples): the one rule that
`to_uniform`, `Signal.n_gaps` and the decay window's gap handling share."""

CHUNK_LINES = 65536
"""Lines parsed at a time: reading holds the kept columns plus one chunk of text, however long the file."""

PROGRESS_DELAY_S = 0.5
"""A progress bar appears only when reading lasts longer than this (small files stay quiet)."""

Pick = Callable[[list[str] | None, int], Sequence[int]]
"""Chooses the column indices to keep, given the header (None when the file has none) and the column count."""


@dataclass(frozen=True)
class Table:
    """The numeric columns kept from a CSV file, with its header and column count."""

    header: list[str] | None
    """Column names, or None when the first row is all numbers."""
    ncols: int
    columns: tuple[int, ...]
    """Indices of the kept columns, in the order of `data`'s columns."""
    values: tuple[np.ndarray, ...]
    """One float array per kept column (each its own contiguous block, so a caller can keep one and free the others);
    blank, nan and inf cells are NaN/inf."""

    @property
    def data(self) -> np.ndarray:
        """The kept columns as a float matrix, one row per data line (a copy)."""
        return np.column_stack(self.values) if self.values else np.empty((0, 0))


VIDEO_LIKE = (".mp4", ".mov", ".m4v", ".avi", ".mkv", ".webm")
"""Suffixes that mark a video given where a table (a signal, a pose log) was expected."""


def refuse_video(p: Path, video_message: str, wanted: str) -> None:
    """Refuse a file named as a video where a table was expected: a video with `video_message`; a file that only bears
    a video's name, being text or empty, as neither a video nor `wanted` (what was expected: "a table ..."). Every video
    container's first bytes hold a zero byte (its sizes), text none: a text file named .mp4 was called a video."""
    if p.suffix.lower() not in VIDEO_LIKE:
        return
    if p.is_file():  # a pipe is not read here: its bytes are the reader's
        with open(p, "rb") as fh:
            head = fh.read(4096)
        if b"\0" not in head:
            raise UserError(f"{p} is neither a video ({'it holds text' if head else 'it is empty'}) nor {wanted}.")
    raise UserError(video_message)


def read_table(p: Path, pick: Pick | None = None, progress: bool = False) -> Table:
    """Numeric columns of a CSV (`,` `;` tab or whitespace, sniffed; header optional) read in chunks by NumPy's C
    parser, so that a million rows take seconds and little memory; `pick` keeps only the columns it names.

    A cell that is not a number, or a row with another number of cells, is refused with its line number. Lines that
    start with `#` are comments (a logger's notes); the last one before headerless data is its header when it names
    as many columns (NumPy's savetxt writes the header so)."""
    refuse_video(p, f"{p} is a video, not a table; `sloshid track` measures a video into a CSV.", "a CSV table")
    bar = tqdm(
        total=p.stat().st_size,
        unit="B",
        unit_scale=True,
        desc=f"read {p.name}",
        leave=False,
        delay=PROGRESS_DELAY_S,
        disable=None if progress else True,
    )
    with open_input(p) as fh, bar:
        chunks = _decoded_chunks(p, fh, bar)
        first_line, lines = next(chunks, (1, []))
        if not any(line.strip() for line in lines):
            raise UserError(f"{p} is empty.")
        body = [line for line in lines if not _comment(line)]
        if not any(line.strip() for line in body):
            raise UserError(f"{p} holds only comment lines (starting with #), no data.")
        delimiter = _delimiter(body[:200])
        first_row = next(cells for line in body if (cells := _split([line], delimiter)[0]))
        header = None if all(_is_number(c) for c in first_row if c) else first_row
        if header is None:
            header = _commented_header(lines, delimiter, len(first_row))
        data_lines = _data_lines(lines, first_line, header is not None and header is first_row)
        ncols = len(_split([data_lines[0][1]], delimiter)[0]) if data_lines else len(first_row)
        cols = tuple(pick(header, ncols)) if pick is not None else tuple(range(ncols))
        # the rows the file holds if its lines are as long as the first chunk's: the columns are allocated once and
        # grown in place if not, so that reading never holds the parsed numbers twice
        text_bytes = sum(len(line) + 1 for line in lines)
        rows = int(p.stat().st_size * max(len(data_lines), 1) / max(text_bytes, 1) * 1.05) + 1024
        out = _Columns(len(cols), rows)
        out.append(_parse(data_lines, delimiter, cols, ncols, p, header))
        del lines, data_lines  # only one chunk of text is held at a time
        for k, ls in chunks:
            out.append(_parse(_data_lines(ls, k, False), delimiter, cols, ncols, p, header))
    return Table(header, ncols, cols, out.finish())


class _Columns:
    """Float columns filled chunk by chunk: preallocated, grown and trimmed in place (realloc: no second copy)."""

    def __init__(self, k: int, rows: int):
        self.cols = [np.empty(rows) for _ in range(k)]
        self.n = 0

    def append(self, block: np.ndarray) -> None:
        """Copy a chunk's (rows, k) floats in after the rows already held."""
        end = self.n + block.shape[0]
        for j, col in enumerate(self.cols):
            if end > col.size:
                col.resize(max(end, col.size + col.size // 4), refcheck=False)  # zero-filled: grow modestly
            col[self.n : end] = block[:, j]
        self.n = end

    def finish(self) -> tuple[np.ndarray, ...]:
        """The columns cut to the rows read."""
        for col in self.cols:
            col.resize(self.n, refcheck=False)
        return tuple(self.cols)


def _decoded_chunks(p: Path, fh: BinaryIO, bar: tqdm) -> Iterator[tuple[int, list[str]]]:
    """(number of the first line, decoded lines) for CHUNK_LINES lines at a time; a byte-order mark is dropped."""
    line = 1
    while raw := list(itertools.islice(fh, CHUNK_LINES)):
        blob = b"".join(raw)
        bar.update(len(blob))
        try:
            text = blob.decode("utf-8-sig" if line == 1 else "utf-8")
        except UnicodeDecodeError as exc:
            bad = line + blob.count(b"\n", 0, exc.start)
            raise UserError(
                f"{p} is not UTF-8 text (byte 0x{blob[exc.start]:02X} on line {bad}); if it is a CSV saved in another "
                "encoding (e.g. Latin-1), re-save it as UTF-8."
            ) from None
        yield line, text.splitlines()
        line += len(raw)


def _delimiter(lines: list[str]) -> str:
    """The delimiter of a CSV's first lines: `,` `;` or tab as sniffed, else ' ' (any run of whitespace) when that
    splits the lines into columns, else `,`."""
    sample = [line for line in lines if line.strip()]
    try:
        return csv.Sniffer().sniff("\n".join(sample), delimiters=",;\t ").delimiter
    except csv.Error:
        widths = {len(line.split()) for line in sample}
        return " " if len(widths) == 1 and widths.pop() > 1 else ","


def _split(lines: Sequence[str], delimiter: str) -> list[list[str]]:
    """Cells of each line (quotes honoured; whitespace-delimited lines split on any run of blanks)."""
    if delimiter == " ":
        return [line.split() for line in lines]
    return [[c.strip() for c in row] for row in csv.reader(lines, delimiter=delimiter)]


def _comment(line: str) -> bool:
    """A comment line: its first non-blank character is `#`."""
    return line.lstrip().startswith("#")


def _commented_header(lines: list[str], delimiter: str, ncols: int) -> list[str] | None:
    """The last comment line before the first data line as column names, when it has `ncols` cells, not all
    numbers (`# t_s,angle_deg`, as NumPy's savetxt writes a header); else None."""
    last = None
    for line in lines:
        if _comment(line):
            last = line
        elif line.strip():
            break
    if last is None:
        return None
    cells = _split([last.lstrip()[1:].strip()], delimiter)[0]
    return cells if len(cells) == ncols and not all(_is_number(c) for c in cells if c) else None


def _data_lines(lines: list[str], first_line: int, skip_header: bool) -> list[tuple[int, str]]:
    """(line number, text) of the non-blank, non-comment lines, without the header line when it is among them."""
    numbered = [(k, line) for k, line in enumerate(lines, start=first_line) if line.strip() and not _comment(line)]
    return numbered[1:] if skip_header else numbered


def _parse(
    lines: list[tuple[int, str]], delimiter: str, cols: tuple[int, ...], ncols: int, p: Path, header: list[str] | None
) -> np.ndarray:
    """The kept columns of one chunk as floats: NumPy's parser first, a cell-by-cell pass to name the bad line."""
    text = [line for _, line in lines]
    if not text:
        return np.empty((0, len(cols)))
    try:
        return np.loadtxt(
            text, delimiter=None if delimiter == " " else delimiter, usecols=cols, ndmin=2, comments=None, quotechar='"'
        )
    except ValueError:
        return _parse_cells(lines, delimiter, cols, ncols, p, header)


def _parse_cells(
    lines: list[tuple[int, str]], delimiter: str, cols: tuple[int, ...], ncols: int, p: Path, header: list[str] | None
) -> np.ndarray:
    """The slow pass over a chunk NumPy refused: blank cells become NaN; a row too short for the kept columns or a
    cell that is not a number is one sentence naming its line."""
    out = np.empty((len(lines), len(cols)))
    for r, ((line, _), cells) in enumerate(zip(lines, _split([t for _, t in lines], delimiter))):
        if len(cells) <= max(cols, default=-1):
            raise UserError(f"{p} line {line} has {len(cells)} cells, the first data line has {ncols}.")
        for j, i in enumerate(cols):
            try:
                out[r, j] = float(cells[i]) if cells[i] else math.nan
            except ValueError:
                name = header[i] if header and i < len(header) else f"column {i}"
                raise UserError(f"{p} line {line}: '{name}' holds '{cells[i]}', which is not a number.") from None
    return out


def _is_number(cell: str) -> bool:
    """True when the cell parses as a number."""
    try:
        float(cell)
        return True
    except ValueError:
        return False
