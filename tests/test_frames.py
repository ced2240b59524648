"""Decoded pictures converted box by box, and the tracker's robust line fit: the same numbers as the whole-frame and
library routes they replace for speed."""

from __future__ import annotations

import subprocess
import sys

import cv2
import numpy as np
import pytest

from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.tracking.robust import masked_median, median, robust_lines
from sloshid.video.frames import FrameReader, Picture, shrunk
from sloshid.video.keyframes import key_frame_times


def _planes(bgr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Y, U and V planes of a BGR picture (4:2:0, as a decoder hands them over)."""
    h, w = bgr.shape[:2]
    i420 = cv2.cvtColor(bgr, cv2.COLOR_BGR2YUV_I420).reshape(-1)
    q = h * w // 4
    return (
        i420[: h * w].reshape(h, w),
        i420[h * w : h * w + q].reshape(h // 2, w // 2),
        i420[h * w + q :].reshape(h // 2, w // 2),
    )


def test_picture_slices_equal_the_whole_conversion():
    # odd and even edges, boxes at the border, nested boxes served from the kept conversion, empty boxes:
    # every slice must be pixel for pixel the same slice of the whole picture converted at once
    rng = np.random.default_rng(4)
    bgr = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    picture = Picture(*_planes(bgr))
    whole = np.asarray(picture)
    assert whole.shape == picture.shape == (48, 64, 3) and whole.flags.writeable
    for y0, y1, x0, x1 in [(3, 17, 5, 30), (4, 16, 6, 30), (0, 48, 0, 64), (45, 60, 61, 70), (10, 12, 10, 11)]:
        np.testing.assert_array_equal(picture[y0:y1, x0:x1], whole[y0:y1, x0:x1])
    assert picture[2:40, 2:60].shape == (38, 58, 3)  # converts and keeps this box
    np.testing.assert_array_equal(picture[5:9, 7:13], whole[5:9, 7:13])  # inside the kept box
    assert picture[10:10, 3:9].shape == (0, 6, 3)


def test_reader_pictures_and_arrays_agree(tmp_path):
    # the tracker's lazy pictures and the plain BGR frames of the same file: same count, times and pixels
    render_video(tmp_path / "v.mp4", SynthSettings(width=160, height=120, fps=30, duration_s=0.5, seed=2))
    arrays = list(FrameReader(tmp_path / "v.mp4", multithreaded=False))
    pictures = list(FrameReader(tmp_path / "v.mp4", pictures=True))
    assert len(arrays) == len(pictures) == 15
    for (i, t, a), (j, u, p) in zip(arrays, pictures):
        assert i == j and t == u
        np.testing.assert_array_equal(np.asarray(p), a)
        np.testing.assert_array_equal(p[31:77, 9:100], a[31:77, 9:100])


def test_a_shrunk_picture_averages_blocks_of_pixels_as_its_array_does(tmp_path):
    # a picture of gradients (about a grey level per pixel) of odd size reduced three times: the Picture's planes
    # averaged before conversion give the BGR array averaged after it within 4 grey levels (the result's chroma is
    # shared by 2x2 of its pixels, 6x6 of the picture's: up to 3 levels of the gradient, plus rounding); the result
    # is even-sized, its pixel x the average of the picture's 3x .. 3x + 2
    yy, xx = np.mgrid[0:100, 0:146]
    bgr = np.dstack([40 + xx, 60 + yy, 200 - (xx + yy) // 3]).astype(np.uint8)
    picture = Picture(*_planes(bgr))
    small = np.asarray(shrunk(picture, 3))
    assert small.shape == shrunk(bgr, 3).shape == (32, 48, 3)
    assert np.abs(small.astype(int) - shrunk(np.asarray(picture), 3).astype(int)).max() <= 4
    assert abs(int(shrunk(bgr, 3)[5, 7, 0]) - int(bgr[15:18, 21:24, 0].mean().round())) <= 1
    render_video(tmp_path / "v.mp4", SynthSettings(width=160, height=120, fps=30, duration_s=0.2, seed=2))
    for (_, _, a), (_, _, p) in zip(FrameReader(tmp_path / "v.mp4", False), FrameReader(tmp_path / "v.mp4", shrink=2)):
        assert p.shape == (60, 80, 3)
        np.testing.assert_array_equal(p, shrunk(a, 2))


_INTERRUPTED_START = """
import sys, threading
from sloshid.video.frames import FrameReader
start = threading.Thread.start
def start_then_interrupted(thread):
    start(thread)
    raise KeyboardInterrupt
threading.Thread.start = start_then_interrupted
before = set(threading.enumerate())
try:
    next(iter(FrameReader(sys.argv[1], pictures=True)))
except KeyboardInterrupt:
    pass
print(sum(t.is_alive() for t in set(threading.enumerate()) - before))
"""


def test_an_interruption_while_the_decoding_thread_starts_still_joins_it(tmp_path):
    # SIGTERM's handler raises in the main thread wherever it is; the likeliest place at the start of tracking is
    # Thread.start waiting for the new thread. The reader must then still stop and join that thread before it
    # closes the file: a thread decoding a closed file crashes the process (exit -11 in CI, about 1 in 10 SIGTERMs).
    # In a separate process, so that the crash fails this test instead of ending the whole run.
    render_video(tmp_path / "v.mp4", SynthSettings(width=160, height=120, fps=30, duration_s=2.0, seed=2))
    proc = subprocess.run(
        [sys.executable, "-c", _INTERRUPTED_START, tmp_path / "v.mp4"], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "0"  # no thread of the reader is left running


def test_robust_line_is_the_least_squares_line_of_its_inliers():
    # a wall edge with 0.2 px noise and a highlight that pulls 15 rows by 5 px: the highlight is dropped and the
    # line is np.polyfit's on the rows kept (to rounding), within 0.01 px/row of the true slope (0.2 px noise
    # over 150 rows gives a slope error of about 0.0005)
    rng = np.random.default_rng(8)
    y = np.arange(40.0, 190.0)
    x = 0.05 * y + 100 + rng.normal(0, 0.2, y.size)
    x[60:75] += 5.0
    x[3] = np.nan
    (coef,), (keep,) = robust_lines(y, x[None], np.ones((1, y.size), bool), 0.3)
    assert not keep[60:75].any() and not keep[3] and keep.sum() > 120
    np.testing.assert_allclose(coef, np.polyfit(y[keep], x[keep], 1), rtol=1e-9)
    assert coef[0] == pytest.approx(0.05, abs=0.01)
    one_column = robust_lines(np.full(20, 3.0), np.arange(20.0)[None], np.ones((1, 20), bool), 0.3)[0]
    assert np.isnan(one_column).all()  # no line


def test_robust_lines_fit_each_row_as_alone():
    # the batched fit (the container walls' four edges at once) gives each row the line and inliers it gets alone,
    # whatever the other rows hold: outliers, masked points, too few points (NaN), all at one t (NaN)
    rng = np.random.default_rng(10)
    t = np.arange(0.0, 120.0)
    v = np.stack([0.02 * t + 50, -0.04 * t + 80, 0.01 * t + 5, np.full(t.size, 7.0)]) + rng.normal(0, 0.2, (4, t.size))
    v[0, 30:45] += 6.0
    ok = np.ones(v.shape, bool)
    ok[1, ::3] = False
    ok[2, 9:] = False  # nine points left: too few
    ok[3] = t == 40  # every usable point at one t
    coef, keep = robust_lines(t, v, ok, 0.3)
    for row in range(2):
        alone = robust_lines(t[ok[row]], v[row, ok[row]][None], np.ones((1, ok[row].sum()), bool), 0.3)
        np.testing.assert_allclose(coef[row], alone[0][0], rtol=1e-9)
        np.testing.assert_array_equal(keep[row, ok[row]], alone[1][0])
    assert not keep[0, 30:45].any() and coef[0, 0] == pytest.approx(0.02, abs=0.002)
    assert np.isnan(coef[2:]).all()
    # a free variable per row (the walls over rows, the bottom over columns) and a minimum count per row
    shifted, fewer = np.stack([t, t + 300, t, t]), np.array([10, 10, 9, 10])
    coef2, _ = robust_lines(shifted, v, ok, 0.3, min_points=fewer)
    alone = robust_lines(t[ok[1]] + 300, v[1, ok[1]][None], np.ones((1, ok[1].sum()), bool), 0.3)
    np.testing.assert_allclose(coef2[1], alone[0][0], rtol=1e-9)
    np.testing.assert_allclose(coef2[0], coef[0], rtol=1e-9)
    assert np.isfinite(coef2[2]).all() and np.isnan(coef2[3]).all()  # nine points are enough for that row


def _trimmed_line(t, v, floor, min_points=10, iterations=3):
    """The trimmed line fit written plainly for one line, as the reference for the batched one: least squares,
    drop points more than max(3 * 1.4826 * MAD, floor) off, refit until the inliers repeat; None when fewer than
    `min_points` stay."""
    keep = np.isfinite(v)
    for passes in range(iterations + 1):
        if keep.sum() < min_points or np.ptp(t[keep]) == 0:
            return None, keep
        coef = np.polyfit(t[keep], v[keep], 1)
        if passes == iterations:
            break
        res = np.abs(v - np.polyval(coef, t))  # NaN off every line
        new = res < max(3 * 1.4826 * np.median(res[keep]), floor)
        if np.array_equal(new, keep):
            break
        keep = new
    return (coef, keep) if keep.sum() >= min_points else (None, keep)


def test_robust_lines_match_a_plain_fit_of_each_line():
    # random rows, padded and masked, with outliers and few points: each row's line and inliers are the plain
    # single-line fit's, and a row the plain fit leaves short of points gets none (a row once short used to come
    # back with a line through its outliers)
    rng = np.random.default_rng(12)
    short = np.array([0, -0.1, -0.1, 0.1, 0.2, -13, 5.2, 0.4, -7, -0.2, -0.2, 9.7, -0.1])  # found by a review
    assert _trimmed_line(np.arange(13.0), short, 0.3)[0] is None
    assert np.isnan(robust_lines(np.arange(13.0), short[None], np.ones((1, 13), bool), 0.3)[0]).all()
    lines = none = 0
    for _ in range(300):
        rows, length = int(rng.integers(1, 5)), int(rng.integers(11, 60))
        t = 500 + np.cumsum(rng.random((rows, length)) * 2, axis=1)
        v = rng.normal(0, 0.2, (rows, length)) + rng.normal(0, 0.05, (rows, 1)) * t
        out = rng.random(v.shape) < 0.3
        v[out] += rng.normal(0, 8, out.sum())
        ok = rng.random(v.shape) > 0.1
        coef, keep = robust_lines(t, v, ok, 0.3)
        for r in range(rows):
            plain, inliers = _trimmed_line(t[r, ok[r]], v[r, ok[r]], 0.3)
            if plain is None:
                none += 1
                assert np.isnan(coef[r]).all()
            else:
                lines += 1
                np.testing.assert_allclose(coef[r], plain, rtol=1e-7, atol=1e-9)
                np.testing.assert_array_equal(keep[r, ok[r]], inliers)
    assert lines > 500 and none > 10  # both kinds were met (measured: 738 and 17)


def test_masked_median_matches_numpy():
    rng = np.random.default_rng(11)
    values = rng.normal(size=(5, 31))
    mask = rng.random(values.shape) < 0.6
    mask[4] = False
    got = masked_median(values, mask)
    for row in range(4):
        assert got[row] == pytest.approx(float(np.median(values[row, mask[row]])), abs=1e-15)
    assert np.isnan(got[4])


def test_median_matches_numpy():
    rng = np.random.default_rng(9)
    for n in (1, 2, 7, 50, 51):
        values = rng.normal(size=n)
        assert median(values) == pytest.approx(float(np.median(values)), abs=1e-15)


def test_a_reader_from_a_key_frame_yields_what_a_reader_from_the_start_does(tmp_path):
    # MPEG-4 puts a key frame every 12 frames: a span from the second or third key frame (found by seeking) and a span
    # ending at the next one give exactly the frames, times and pixels of one reader from the start
    path = tmp_path / "k.mp4"
    render_video(path, SynthSettings(width=160, height=120, fps=30, duration_s=1.5, codec="mpeg4", seed=3))
    whole = list(FrameReader(path, multithreaded=False))
    keys = key_frame_times(path)
    assert len(keys) >= 3
    for start, end in ((keys[1], keys[2]), (keys[2], None)):
        span = list(FrameReader(path, multithreaded=False, start_s=float(start), end_s=end))
        want = [(t, a) for _, t, a in whole if t >= start and (end is None or t < end)]
        assert [t for _, t, _ in span] == [t for t, _ in want] and len(span) > 0
        for (_, _, a), (_, b) in zip(span, want):
            np.testing.assert_array_equal(a, b)
