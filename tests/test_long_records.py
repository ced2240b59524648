"""Long records (issue 40): the block-by-block forms that keep identify's memory per row low compute the same numbers
as the SciPy calls they replace (bit for bit where the arithmetic is the same, to rounding for Welch's detrending)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy import signal as sps

from sloshid.core import spectrum
from sloshid.identification import decay_window
from sloshid.identification.estimator import min_max_envelope

N = 300_001  # past one block (2**18 samples), so that every block border is crossed


def _record(seed: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A noisy 3 Hz decay with a slow drift at 1 kHz."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / 1000.0
    y = 5 * np.exp(-0.2 * t) * np.cos(18.85 * t) + 0.01 * t + rng.normal(0, 0.05, N)
    return t, y


def test_swing_and_running_mean_equal_scipys_filters_bit_for_bit():
    _, y = _record()
    slow = np.cumsum(np.random.default_rng(5).normal(size=N)) * 1e-3
    for n in (4, 333):
        span = ndimage.maximum_filter1d(y - slow, n, mode="nearest") - ndimage.minimum_filter1d(
            y - slow, n, mode="nearest"
        )
        reference = ndimage.uniform_filter1d(span, n, mode="nearest") / 2
        np.testing.assert_array_equal(decay_window._swing(y, n, minus=slow), reference)


def test_block_sosfiltfilt_equals_scipys_bit_for_bit():
    _, y = _record()
    sos = sps.butter(6, 1.5, fs=1000.0, output="sos")
    np.testing.assert_array_equal(decay_window._sosfiltfilt_blocks(sos, y, 2000), sps.sosfiltfilt(sos, y, padlen=2000))


def test_period_mean_in_place_equals_the_plain_formula():
    t, y = _record()
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])
    lo = np.clip(t - 1 / 6, t[0], t[-1] - 1 / 3)
    reference = (np.interp(lo + 1 / 3, t, integral) - np.interp(lo, t, integral)) / (1 / 3)
    np.testing.assert_array_equal(decay_window.period_mean(t, y, 1 / 3), reference)


def test_lean_welch_equals_scipys_welch_to_rounding():
    _, y = _record()
    y = np.concatenate([y, y[::-1]])  # 600 002 samples: segments past LEAN_WELCH_SAMPLES
    seg = y.size // 2
    nfft = spectrum._pow2(seg)
    f, p = sps.welch(
        y - y.mean(), fs=1000.0, window="hann", nperseg=seg, noverlap=seg // 2, nfft=nfft, detrend="linear"
    )
    f_lean, p_lean = spectrum._lean_welch(y, 1000.0, seg, nfft)
    np.testing.assert_array_equal(f_lean, f)
    np.testing.assert_allclose(p_lean, p, rtol=1e-9, atol=1e-12 * p.max())


def test_plotted_envelope_keeps_every_extreme_in_time_order():
    t, y = _record()
    tt, yy = min_max_envelope(t, y, columns=1000)
    assert tt.size <= 2002 and np.all(np.diff(tt) > 0)
    assert yy.max() == y.max() and yy.min() == y.min()
    short_t, short_y = min_max_envelope(t[:100], y[:100], columns=1000)
    np.testing.assert_array_equal(short_t, t[:100])
    np.testing.assert_array_equal(short_y, y[:100])
