"""The one CSV reader (core.tables.read_table): chunked C parsing gives the same numbers as NumPy on the whole file,
names bad lines correctly in any chunk, holds memory to the kept columns, and shows progress on a terminal."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from sloshid.core import tables
from sloshid.core.errors import UserError
from sloshid.core.tables import read_table, table_to_csv


@pytest.fixture
def small_chunks(monkeypatch):
    """Chunks of 1000 lines, so that a few thousand rows cross several chunk borders."""
    monkeypatch.setattr(tables, "CHUNK_LINES", 1000)


def write_rows(path, rows: np.ndarray, header: str | None = "t_s;a;b;angle_deg", sep: str = ";") -> None:
    """A CSV of the rows (9 significant digits), optionally with a header."""
    lines = ([header] if header else []) + [sep.join(f"{v:.9g}" for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def test_chunked_read_equals_numpy_on_the_whole_file(tmp_path, small_chunks):
    rng = np.random.default_rng(1)
    rows = rng.normal(size=(5500, 4))
    p = tmp_path / "s.csv"
    write_rows(p, rows)
    table = read_table(p, lambda header, ncols: [header.index("angle_deg"), 0])
    reference = np.loadtxt(p, delimiter=";", skiprows=1, usecols=(3, 0))
    # the same text parsed by the same C parser: equal to the last bit, across five chunk borders
    assert table.header == ["t_s", "a", "b", "angle_deg"]
    assert table.ncols == 4
    np.testing.assert_array_equal(table.data, reference)


def test_blank_cells_become_nan_and_blank_lines_are_skipped(tmp_path, small_chunks):
    rows = np.arange(3000 * 2, dtype=float).reshape(3000, 2)
    p = tmp_path / "s.csv"
    write_rows(p, rows, header="t_s,angle_deg", sep=",")
    lines = p.read_text().splitlines()
    lines[2500] = f"{rows[2499, 0]:.9g},"  # line 2501 (data row 2500) loses its value, in the third chunk
    lines.insert(1200, "")
    p.write_text("\n".join(lines) + "\n")
    data = read_table(p).data
    assert data.shape == (3000, 2)
    assert np.isnan(data[2499, 1]) and np.isnan(data[:, 1]).sum() == 1
    np.testing.assert_array_equal(data[:, 0], rows[:, 0])


def test_bad_cell_and_bad_byte_are_named_by_their_line_in_a_later_chunk(tmp_path, small_chunks):
    rows = np.ones((4000, 2))
    p = tmp_path / "s.csv"
    write_rows(p, rows, header="t_s,angle_deg", sep=",")
    lines = p.read_text().splitlines()
    lines[3210] = "1,abc"  # line 3211 of the file
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match="line 3211: 'angle_deg' holds 'abc', which is not a number"):
        read_table(p)
    lines[3210] = "1,1"
    p.write_bytes(("\n".join(lines[:2999]) + "\n").encode() + b"1,\xe9\n" + ("\n".join(lines[3000:]) + "\n").encode())
    with pytest.raises(UserError, match="byte 0xE9 on line 3000"):
        read_table(p)


def test_whitespace_and_quoted_cells(tmp_path):
    p = tmp_path / "w.txt"
    p.write_text("0.0   1.5\n0.1\t -2.5 \n0.2 3\n" * 10)
    data = read_table(p).data
    assert read_table(p).header is None
    np.testing.assert_array_equal(data[:3], [[0.0, 1.5], [0.1, -2.5], [0.2, 3.0]])
    q = tmp_path / "q.csv"
    q.write_text('"t_s","angle_deg"\n"0.5","1.25"\n"1.0","2.5"\n')
    assert read_table(q).header == ["t_s", "angle_deg"]
    np.testing.assert_array_equal(read_table(q).data, [[0.5, 1.25], [1.0, 2.5]])


def peak_bytes(path) -> int:
    """Peak Python allocation while reading two of the file's six columns."""
    tracemalloc.start()
    read_table(path, lambda header, ncols: [0, 5])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak


def test_memory_grows_with_the_kept_columns_not_the_text(tmp_path, small_chunks):
    rng = np.random.default_rng(2)
    n = 50_000
    small, large = tmp_path / "n.csv", tmp_path / "2n.csv"
    rows = rng.normal(size=(2 * n, 6))
    write_rows(small, rows[:n], header="t_s,a,b,c,d,angle_deg", sep=",")
    write_rows(large, rows, header="t_s,a,b,c,d,angle_deg", sep=",")
    growth_per_row = (peak_bytes(large) - peak_bytes(small)) / n
    # the kept columns cost 16 bytes a row, twice while the chunks are joined: 32 (43 measured with the blocks'
    # overhead); holding the text as rows of cells, as the reader before this one did, cost 850 bytes a row here
    assert growth_per_row < 64, growth_per_row


def test_a_tracker_csv_is_read_into_its_signal_at_under_34_bytes_a_row(tmp_path, small_chunks):
    # issue 40: identify held 10 million rows at about 100 bytes a row. Reading a tracker CSV keeps t_s, angle_deg and
    # valid, 24 bytes a row, in columns allocated once (5 % slack) and handed to the signal without a copy when every
    # frame is valid; 34 leaves room for the time steps the signal's checks take. The reader before this one joined
    # the chunks into a second matrix and copied the valid rows out of it: 48 bytes a row and more.
    from sloshid.identification.signals import load_signal

    n = 100_000
    t = np.arange(2 * n) / 1000.0
    y = np.sin(2 * np.pi * 3.0 * t) + np.random.default_rng(3).normal(0, 0.05, t.size)
    small, large = tmp_path / "n.csv", tmp_path / "2n.csv"
    for path, rows in ((small, n), (large, 2 * n)):
        table = np.column_stack([t[:rows], y[:rows], np.ones(rows), np.full(rows, 0.9)])
        np.savetxt(
            path,
            table,
            fmt=["%.6f", "%.6f", "%d", "%.3f"],
            delimiter=",",
            header="t_s,angle_deg,valid,quality",
            comments="",
        )

    def peak(path) -> int:
        tracemalloc.start()
        sig = load_signal(path)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert sig.t_s.size == int(path.stat().st_size > small.stat().st_size) * n + n
        return peak

    growth_per_row = (peak(large) - peak(small)) / n
    assert growth_per_row < 34, growth_per_row


def test_progress_bar_is_drawn_on_a_terminal_only_when_asked(tmp_path, monkeypatch, stderr_as):
    p = tmp_path / "long.csv"
    write_rows(p, np.ones((2000, 4)))
    monkeypatch.setattr(tables, "PROGRESS_DELAY_S", 0.0)
    for progress in (True, False):
        err = stderr_as(terminal=True)
        read_table(p, progress=progress)
        assert ("read long.csv" in err.getvalue()) is progress


def test_comment_lines_are_skipped_and_a_commented_header_is_read(tmp_path, small_chunks):
    # a DAQ's notes above the header, a note inside the data (past a chunk border), and NumPy's savetxt header
    # '# t_s;a;b;angle_deg': comments were read as the header or as data ("has only one column")
    rows = np.random.default_rng(2).normal(size=(2500, 4))
    p = tmp_path / "c.csv"
    write_rows(p, rows)
    lines = p.read_text().splitlines()
    lines.insert(1500, "# operator paused here")
    p.write_text("# logged by DAQ v2\n# fs = 100 Hz\n" + "\n".join(lines) + "\n")
    table = read_table(p)
    assert table.header == ["t_s", "a", "b", "angle_deg"]
    np.testing.assert_allclose(table.data, rows, rtol=1e-8)
    saved = tmp_path / "saved.csv"
    np.savetxt(saved, rows, delimiter=";", header="t_s;a;b;angle_deg")
    table = read_table(saved)
    assert table.header == ["t_s", "a", "b", "angle_deg"]
    np.testing.assert_allclose(table.data, rows)
    (tmp_path / "notes.csv").write_text("# nothing but notes\n")
    with pytest.raises(UserError, match="only comment lines"):
        read_table(tmp_path / "notes.csv")


def test_a_negative_zero_is_written_as_0():
    # a trial's predict CSV held "-0" cells (a zero relative roll times a negative factor); every other value keeps
    # its bits, the time column its exact form
    text = table_to_csv({"t_s": np.array([-0.0, 0.1]), "a_deg": np.array([-0.0, -1e-12]), "n": np.array([0, 1])})
    assert text.splitlines()[1:] == ["0.0,0,0", "0.1,-1e-12,1"]
