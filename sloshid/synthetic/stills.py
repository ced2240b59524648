"""Still clips from one picture: the picture turned by a known angle, with fresh sensor noise in every frame and
H.264 compression, so that a tracker can be checked on footage no renderer made (a real photo) against the one thing
known about it, the rotation."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from sloshid.core.atomic import atomic_path
from sloshid.video.frames import VideoWriter


def rotated(
    image: np.ndarray, angle_deg: float, width: int | None = None, corners: tuple[int, int, int] | None = None
) -> np.ndarray:
    """The picture turned by `angle_deg` (counter-clockwise as seen) about its centre, its corners filled by
    reflection (or with the colour `corners`, as a photo editor turns a picture), then scaled to `width` pixels across
    (its aspect kept; None: as it is)."""
    h, w = image.shape[:2]
    turn = cv2.getRotationMatrix2D((0.5 * (w - 1), 0.5 * (h - 1)), angle_deg, 1.0)
    fill = {"borderMode": cv2.BORDER_REFLECT} if corners is None else {"borderValue": corners}
    out = cv2.warpAffine(image, turn, (w, h), flags=cv2.INTER_CUBIC, **fill)
    if width is None or width == w:
        return out
    return cv2.resize(out, (width, round(h * width / w)), interpolation=cv2.INTER_AREA)


def still_clip(
    image: np.ndarray,
    path: str | Path,
    angle_deg: float = 0.0,
    frames: int = 15,
    fps: float = 30.0,
    noise: float = 3.0,
    crf: float = 20.0,
    width: int | None = None,
    seed: int = 0,
    corners: tuple[int, int, int] | None = None,
) -> None:
    """Write an H.264 clip of `frames` frames of the picture turned by `angle_deg` (`rotated`, `corners` its fill),
    each with fresh Gaussian sensor noise of `noise` grey levels (seeded), at constant quality `crf`."""
    rng = np.random.default_rng(seed)
    picture = rotated(image, angle_deg, width, corners).astype(np.float32)
    h, w = picture.shape[:2]
    with atomic_path(path) as tmp, VideoWriter(tmp, w, h, fps, "h264", crf) as writer:
        for i in range(frames):
            grain = rng.normal(0.0, noise, picture.shape).astype(np.float32)
            writer.write(np.clip(picture + grain, 0, 255).astype(np.uint8), i / fps)


def recoloured(
    image: np.ndarray,
    turn_hue: int = 0,
    value: float = 1.0,
    region: tuple[int, int, int, int] | None = None,
    saturation: float = 1.0,
) -> np.ndarray:
    """The picture with every hue turned by `turn_hue` (OpenCV units, 2 deg each) and every saturation scaled by
    `saturation`, and the coloured pixels (saturation above 80 of 255) of `region` (x0, y0, x1, y1; None: none)
    darkened to `value` of their brightness: a real photo's dye made another colour, fainter or darker, for the dyes
    no photo at hand shows."""
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    hsv[..., 0] = (hsv[..., 0].astype(int) + turn_hue) % 180
    hsv[..., 1] = np.clip(hsv[..., 1] * saturation, 0, 255).astype(np.uint8)
    if region is not None:
        x0, y0, x1, y1 = region
        box = hsv[y0:y1, x0:x1]
        coloured = box[..., 1] > 80
        box[..., 2][coloured] = (box[..., 2][coloured] * value).astype(np.uint8)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)


def camera_look(
    image: np.ndarray,
    defocus_px: float = 0.0,
    chromatic: float = 0.0,
    vignette: float = 0.0,
    sharpen: float = 0.0,
    jpeg_quality: int | None = None,
) -> np.ndarray:
    """The picture as a phone's camera would have processed it: a Gaussian defocus of `defocus_px`, lateral chromatic
    aberration (red magnified by 1 + `chromatic` about the centre, blue by 1 - `chromatic`: colour fringes at edges
    away from it), a vignette darkening the corners by `vignette`, an unsharp mask of strength `sharpen` (the halos
    beside every edge) and JPEG at `jpeg_quality` (None: none), in that order, as the light meets them."""
    out = image.astype(np.float32)
    if defocus_px > 0:
        out = np.asarray(cv2.GaussianBlur(out, (0, 0), defocus_px), np.float32)
    h, w = out.shape[:2]
    if chromatic:
        centre = (0.5 * (w - 1), 0.5 * (h - 1))
        for channel, scale in ((2, 1.0 + chromatic), (0, 1.0 - chromatic)):
            grow = cv2.getRotationMatrix2D(centre, 0.0, scale)
            out[..., channel] = cv2.warpAffine(
                out[..., channel], grow, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT
            )
    if vignette:
        y, x = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((x - 0.5 * (w - 1)) ** 2 + (y - 0.5 * (h - 1)) ** 2) / (0.25 * (w * w + h * h))
        out *= (1.0 - vignette * r2)[..., None]
    if sharpen:
        out = out + sharpen * (out - cv2.GaussianBlur(out, (0, 0), 1.5))
    picture = np.clip(out, 0, 255).astype(np.uint8)
    if jpeg_quality is None:
        return picture
    _, data = cv2.imencode(".jpg", picture, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
    return np.asarray(cv2.imdecode(data, cv2.IMREAD_COLOR), np.uint8)
