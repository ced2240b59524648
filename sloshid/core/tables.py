"""Column tables as CSV: the contract between stages is the column names (with units), so keep I/O in one place."""

from __future__ import annotations

import csv
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
