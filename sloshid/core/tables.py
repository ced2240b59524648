"""Column tables as CSV: the contract between stages is the column names (with units), so keep I/O in one place."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import numpy as np

from sloshid.core.atomic import write_text
from sloshid.core.errors import UserError


def table_to_csv(columns: dict[str, np.ndarray]) -> str:
    """CSV text of equally long columns: whole numbers without decimals, floats with 9 significant digits."""
    names = list(columns)
    cols = [np.asarray(columns[n]) for n in names]
    fmt = ["%d" if np.issubdtype(c.dtype, np.integer) or c.dtype == bool else "%.9g" for c in cols]
    lines = [",".join(names)]
    lines.extend(",".join(f % v for f, v in zip(fmt, row)) for row in zip(*cols))
    return "\n".join(lines) + "\n"


def write_csv(path: str | Path, columns: dict[str, np.ndarray]) -> None:
    """Write columns to `path` atomically."""
    write_text(path, table_to_csv(columns))


def read_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a numeric CSV written by write_csv into float columns keyed by header name."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        raise UserError(f"{path} does not exist.") from None
    if not rows:
        raise UserError(f"{path} is empty.")
    try:
        data = np.array(rows[1:], dtype=float).reshape(len(rows) - 1, len(rows[0]))
    except ValueError:
        raise UserError(f"{path} is not a numeric CSV table.") from None
    return {name: data[:, i] for i, name in enumerate(rows[0])}


def to_pandas(columns: dict[str, Any]):
    """A pandas DataFrame of equal-length columns (pandas is optional: `pip install sloshid[pandas]`)."""
    try:
        import pandas as pd
    except ImportError:
        raise UserError("to_pandas() needs pandas; install it with `pip install pandas`.") from None
    return pd.DataFrame(columns)


def read_rows(p: Path) -> tuple[list[str] | None, list[list[str]]]:
    """CSV rows with the delimiter (`,` `;` tab or space) sniffed; the header is the first row when it is not all
    numbers (None when the file has no header)."""
    try:
        text = p.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise UserError(
            f"{p} is not UTF-8 text (byte 0x{exc.object[exc.start]:02X} at position {exc.start}); if it is a "
            "CSV saved in another encoding (e.g. Latin-1), re-save it as UTF-8."
        ) from None
    sample = text[:8192]
    try:
        dialect = csv.Sniffer().sniff(sample, delimiters=",;\t ")
    except csv.Error:
        dialect = csv.excel
    rows = [r for r in csv.reader(io.StringIO(text), dialect) if r and any(c.strip() for c in r)]
    if not rows:
        raise UserError(f"{p} is empty.")
    first = [c.strip() for c in rows[0]]

    def numeric(cell: str) -> bool:
        """True when the cell parses as a number."""
        try:
            float(cell)
            return True
        except ValueError:
            return False

    if all(numeric(c) for c in first if c):
        return None, rows
    return first, rows[1:]
