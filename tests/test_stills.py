"""The camera's processing that `camera_look` lays over a picture, measured on pictures whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from sloshid.synthetic.stills import camera_look


def _bar(width: int = 801, height: int = 201, x0: int = 600) -> np.ndarray:
    """A white bar from column x0 to the right edge on black: one edge 200 px right of the centre."""
    image = np.zeros((height, width, 3), np.uint8)
    image[:, x0:] = 255
    return image


def _edge_x(channel: np.ndarray) -> float:
    """The sub-pixel column where the middle row crosses half brightness."""
    row = channel[channel.shape[0] // 2].astype(float)
    k = int(np.argmax(row >= 127.5))
    return k - 1 + (127.5 - row[k - 1]) / (row[k] - row[k - 1])


def test_chromatic_aberration_moves_red_out_and_blue_in_by_the_share_of_the_distance_from_the_centre():
    out = camera_look(_bar(), chromatic=0.005)
    # the edge lies 199.5 px right of the centre (column 400): red magnified by 1.005 moves it ~1 px outward, blue in;
    # linear resampling of a step places it within 0.1 px
    assert _edge_x(out[..., 2]) - _edge_x(out[..., 1]) == pytest.approx(0.005 * 199.5, abs=0.1)
    assert _edge_x(out[..., 0]) - _edge_x(out[..., 1]) == pytest.approx(-0.005 * 199.5, abs=0.1)


def test_the_vignette_darkens_the_corners_by_its_share_and_leaves_the_centre():
    grey = np.full((101, 201, 3), 200, np.uint8)
    out = camera_look(grey, vignette=0.3).astype(float)
    assert out[50, 100].mean() == pytest.approx(200, abs=0.5)  # the centre: no loss
    assert out[0, 0].mean() == pytest.approx(200 * 0.7, abs=1.0)  # a corner: 30 % darker (rounding to whole levels)


def test_sharpening_leaves_a_bright_and_a_dark_halo_beside_an_edge_and_defocus_spreads_it():
    sharp = camera_look(_bar() // 2 + 64, sharpen=1.2)[100, :, 1].astype(int)  # 64 | 191: room for halos either side
    assert sharp[597] < 64 < 191 < sharp[603]
    soft = camera_look(_bar(), defocus_px=2.0)[100, :, 1].astype(int)
    assert soft[597] > 0 and soft[602] < 255  # spread over a few pixels either side
