"""Diagnosis: where the surface tracker's gain and offset on the physically based clips come from (issue 37).

Per dynamic surface clip of the pbr corpus (ROI runs, as in track_pbr.py), for both references: the gain and median
error of the tracked angle against the truth, and the same with the perspective term sin(e) tan(psi) added, e the
camera's elevation and psi its azimuth seen from the container (the renderer's camera, per frame). The truth's line
joins the surface's points in the container's x-z plane; the tracker's joins the ends of the surface ellipse as seen,
the points where the lines of sight graze the wall, which for a container off the optical axis lie psi round the
wall from them, one in front of the axis and one behind it: the camera's elevation lifts one and lowers the other,
turning the line by sin(e) tan(psi). The ellipse's shape does not show psi (a sheared ellipse is still a line plus a
symmetric chord); it takes the focal length, which `fov_deg` gives the tracker (third pair: tracked with the
renderer's field of view). Also: the found walls' width at the surface against the true inner and
outer widths there (the liquid seen through the glass is magnified out to the outer wall).
Prints a table; run from the repository root: python benchmarks/diagnose_surface_pbr.py [clip ...]
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace

import cv2
import numpy as np
from pbr_corpus import CORPUS
from track_pbr import gain_lag, roi_from_boxes, truth_angle

import sloshid.tracking.surface as surface
from sloshid.core.tables import read_csv
from sloshid.synthetic.pbr import PbrRenderer
from sloshid.synthetic.pbr_scene import PbrScene
from sloshid.synthetic.render import SynthSettings
from sloshid.tracking.tracker import TrackSettings, track_video


def renderer(case: dict) -> PbrRenderer:
    """The clip's renderer (its camera, poses and truth; nothing is rendered)."""
    s = replace(SynthSettings(), **case["settings"])
    raw = json.loads((CORPUS / case["scene_json"]).read_text())["scene"]
    return PbrRenderer(s, PbrScene(**{k: tuple(v) if k.endswith("_rgb") else v for k, v in raw.items()}))


def perspective_deg(r: PbrRenderer, frames: int) -> np.ndarray:
    """Per frame, sin(e) tan(psi) in degrees: e and psi of the line of sight to the surface's centre in container
    coordinates (psi from the container's -y axis, toward +x)."""
    out = np.zeros(frames)
    for k in range(frames):
        pose = r.frame_pose(k)
        v = pose.rot.T @ (pose.world(np.array([0.0, 0.0, r.sc.rest_m])) - r.camera.C)
        out[k] = math.degrees(-v[2] / np.linalg.norm(v) * v[0] / v[1])
    return out


def widths(r: PbrRenderer) -> tuple[float, float, float]:
    """Image row of the surface's centre at rest, true inner and outer widths (px) across the picture there."""
    sc, pose = r.sc, r.frame_pose(0)
    half, outer = sc.rest_half_width_m, sc.rest_half_width_m + sc.glass_m
    pts = np.array([[-half, 0, sc.rest_m], [half, 0, sc.rest_m], [-outer, 0, sc.rest_m], [outer, 0, sc.rest_m]])
    px = r.camera.project(pose.world(pts))
    return float(px[:2, 1].mean()), float(np.hypot(*(px[1] - px[0]))), float(np.hypot(*(px[3] - px[2])))


def found_widths(path, settings: TrackSettings, row: float) -> tuple[object, list[float]]:
    """Track the clip, recording the found walls' distance (px) at the given image row in every measured frame."""
    seen, measure = [], surface.SurfaceFinder.measure

    def recording(self, frame):
        m = measure(self, frame)
        if m.found:
            (aL, bL, *_), (aR, bR, *_) = m.walls
            seen.append((aR - aL) * row + bR - bL)
        return m

    surface.SurfaceFinder.measure = recording
    try:
        return track_video(path, settings, multithreaded=False), seen
    finally:
        surface.SurfaceFinder.measure = measure


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("clips", nargs="*", help="clip names (default: every dynamic surface clip)")
    args = ap.parse_args()
    index = json.loads((CORPUS / "index.json").read_text())
    cases = [c for c in index if c["scene"] == "surface" and c["kind"] != "still"]
    if args.clips:
        cases = [c for c in cases if c["name"] in args.clips]
    print(
        "clip     ref        gain   err med  | +persp: gain  err med | --fov: gain err med | persp range deg | walls/inner  outer/inner"
    )
    for case in cases:
        truth = {k: np.asarray(v) for k, v in read_csv(CORPUS / case["truth"]).items()}
        path = CORPUS / case["video"]
        cap = cv2.VideoCapture(str(path))
        size = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        cap.release()
        boxes = np.column_stack([truth[f"box_{k}_px"] for k in ("x0", "y0", "x1", "y1")])
        roi = roi_from_boxes(boxes, *size)
        r = renderer(case)
        row, inner, outer = widths(r)
        for ref in ("image", "container"):
            res, seen = found_widths(path, TrackSettings(target="surface", reference=ref, roi=roi), row)
            given = track_video(
                path, TrackSettings(target="surface", reference=ref, roi=roi, fov_deg=r.camera.fov_x_deg)
            )
            want = truth_angle(truth, "surface", ref)
            n = min(len(want), len(res.angle_deg))
            ok, t, got, want = res.valid[:n].astype(bool), res.t_s[:n], res.angle_deg[:n], want[:n]
            fixed = got + perspective_deg(r, n)
            figures = []
            for a in (got, fixed, given.angle_deg[:n]):
                g = gain_lag(t[ok], a[ok], want[ok])[0] if ok.sum() > 10 else math.nan
                figures += [g, float(np.median(np.abs(a - want)[ok])) if ok.any() else math.nan]
            p = perspective_deg(r, n)
            print(
                f"{case['name']:8s} {ref:9s} {figures[0]:6.3f} {figures[1]:7.3f}   | {figures[2]:10.3f} {figures[3]:7.3f} | {figures[4]:8.3f} {figures[5]:7.3f} |"
                f" {p.min():+.2f}..{p.max():+.2f}     | {np.median(seen) / inner:8.3f} {outer / inner:11.3f}"
            )


if __name__ == "__main__":
    main()
