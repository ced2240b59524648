"""A float that looks real: rounded ends, slightly curved, a specular spot, partly seen through tinted liquid.

Painted per pixel in the float's own coordinates (x along, y across) with a one-pixel signed-distance ramp. The
shapes stay symmetric about the float's centre along its length (the bend sags both ends alike, the waterline
runs along the float), so the float's angle and centre remain the exact truth; the specular spot is fixed to
the light, not to the float, so the float turns under it as real highlights do.
"""

from __future__ import annotations

import math

import numpy as np

from sloshid.synthetic.scene import LIQUID_BGR, SynthSettings


def _float_distance(x: np.ndarray, y: np.ndarray, L: float, T: float, bend: float, rounded: bool) -> np.ndarray:
    """Signed distance (px, positive inside) to the float outline: a bar or capsule whose ends sag by `bend`."""
    centre = -bend * ((np.clip(x, -L, L) / L) ** 2 - 1 / 3)  # zero mean over the length: the centre stays put
    across = np.abs(y - centre)
    if not rounded:
        return np.minimum(T - across, L - np.abs(x))
    core = L - T
    beyond = np.clip(np.abs(x) - core, 0, None)
    return T - np.hypot(beyond, np.where(beyond > 0, y - centre, across))


def paint_float(img, s: SynthSettings, sc, rel: float, corners: np.ndarray, to_container, bgr) -> None:
    """Blend the realistic float into the float32 image (in place); `corners` bound it in the image."""
    h, w = img.shape[:2]
    pad = 3 + s.float_bend_px
    x0, y0 = np.maximum(np.floor(corners.min(axis=0) - pad).astype(int), 0)
    x1, y1 = np.minimum(np.ceil(corners.max(axis=0) + pad).astype(int) + 1, [w, h])
    if x1 <= x0 or y1 <= y0:
        return
    ys, xs = np.mgrid[y0:y1, x0:x1].astype(np.float64)
    u, v = to_container(xs, ys)
    c, si = math.cos(rel), math.sin(rel)
    fx, fy = u * c + v * si, -u * si + v * c  # container -> float coordinates (inverse rotation)
    L, T = sc.float_l / 2, sc.float_t / 2
    cov = np.clip(0.5 + _float_distance(fx, fy, L, T, s.float_bend_px, s.float_rounded), 0, 1).astype(np.float32)
    region = img[y0:y1, x0:x1]
    region += cov[..., None] * (np.asarray(bgr, np.float32) - region)
    if s.float_submerged > 0:  # the part below the waterline is seen through the tinted liquid
        waterline = -T + 2 * T * s.float_submerged
        under = cov * np.clip(0.5 + waterline - fy, 0, 1).astype(np.float32)
        region += (0.5 * under)[..., None] * (np.asarray(LIQUID_BGR, np.float32) - region)
    if s.float_specular > 0:  # a highlight fixed to the light: offset in container coordinates
        spot = np.exp(-0.5 * (((u - 0.5 * L) ** 2 + (v - 0.3 * T) ** 2) / (0.35 * T) ** 2)).astype(np.float32)
        region += (s.float_specular * spot * cov)[..., None] * (np.float32(255) - region)
