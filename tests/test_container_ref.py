"""The container's walls from the glass's edges (`glass_walls`) on a frame drawn from known geometry: a tapered glass
projected by a pinhole camera above it, its axis leaning in the picture."""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest

from sloshid.tracking.container_ref import (
    STEADY_FLOOR_DEG,
    ContainerTracker,
    EdgeLine,
    beside_sides,
    glass_walls,
    steady_angle,
)
from sloshid.tracking.tracker import TrackSettings, track_video
from sloshid.video.frames import VideoWriter

SS = 8
"""Supersampling of the drawn frame (its edges are anti-aliased)."""


def _camera(lean_deg: float, elevation_deg: float, roll_deg: float):
    """(project, axis_point): a camera 0.5 m away, `elevation_deg` above the glass's mid-height, looking at a point on
    its axis (the case the corpus's renders have), the picture rolled by `roll_deg`; the axis leaning by `lean_deg`."""
    lean = math.radians(lean_deg)
    rot = np.array([[math.cos(lean), 0, -math.sin(lean)], [0, 1, 0], [math.sin(lean), 0, math.cos(lean)]])
    target = rot @ np.array([0.0, 0.0, 0.05])
    e = math.radians(elevation_deg)
    C = target + 0.5 * np.array([0.0, -math.cos(e), math.sin(e)])
    f = (target - C) / np.linalg.norm(target - C)
    r = np.cross(f, [0.0, 0.0, 1.0])
    r /= np.linalg.norm(r)
    R = np.array([r, np.cross(f, r), f])
    a = math.radians(roll_deg)
    R = np.array([[math.cos(a), math.sin(a), 0], [-math.sin(a), math.cos(a), 0], [0, 0, 1]]) @ R
    K = np.array([[900.0, 0, 319.5], [0, 900.0, 239.5], [0, 0, 1]])
    rvec, _ = cv2.Rodrigues(R)

    def project(p):
        px, _ = cv2.projectPoints((np.asarray(p, float) @ rot.T).reshape(-1, 1, 3), rvec, -R @ C, K, None)
        return px.reshape(-1, 2)

    return project


def _solid(project, radius, z0: float, z1: float, grey: int, img: np.ndarray) -> None:
    """Fill a body of revolution (radius(z)) between heights z0 and z1 in the supersampled image."""
    th = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    rings = []
    for z in np.linspace(z0, z1, 40):
        rings.append(project(np.column_stack([radius(z) * np.cos(th), radius(z) * np.sin(th), np.full_like(th, z)])))
    for p, q in itertools.pairwise(rings):
        cv2.fillConvexPoly(img, cv2.convexHull(((np.vstack([p, q]) + 0.5) * SS).astype(np.int32)), grey)


def _tapered_glass(lean_deg=4.0, elevation_deg=10.0, roll_deg=2.0):
    """A tapered glass (radius 30 mm at the bottom, 37 mm at the 100 mm rim, 3 mm wall) two thirds full of dark liquid,
    before a grey wall with a dark box standing upright just beside the rim; the box's edge is not the glass's. Returns
    (BGR frame, axis angle as the picture shows it, the rim's row)."""
    project = _camera(lean_deg, elevation_deg, roll_deg)
    img = np.full((480 * SS, 640 * SS), 200, np.uint8)
    rim = project([[0, 0, 0.1]])[0]
    # a dark box above the rim, its right edge upright and level with the glass's left rim
    x_box = int((project([[-0.037 - 0.003, 0, 0.1]])[0, 0] + 0.5) * SS)
    cv2.rectangle(img, (0, 0), (x_box, int((rim[1] - 10 + 0.5) * SS)), 90, -1)
    _solid(project, lambda z: 0.033 + 0.07 * z, 0.0, 0.1, 160, img)  # the glass, outer face
    _solid(project, lambda z: 0.030 + 0.07 * z, 0.0, 0.1, 185, img)  # the empty glass inside
    _solid(project, lambda z: 0.030 + 0.07 * z, 0.0, 0.066, 70, img)  # the liquid
    grey = cv2.resize(img, (640, 480), interpolation=cv2.INTER_AREA).astype(np.float32)
    grey += np.random.default_rng(3).normal(0.0, 2.0, grey.shape)
    frame = cv2.cvtColor(np.clip(grey, 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
    p0, p1 = project([[0, 0, 0.0], [0, 0, 0.066]])
    axis_deg = math.degrees(math.atan((p1[0] - p0[0]) / (p1[1] - p0[1])))
    return frame, axis_deg, float(rim[1])


def test_the_walls_of_a_tapered_glass_under_perspective_give_its_axis():
    # the walls lean 4 deg either way of the axis; a camera 10 deg above, the picture rolled 2 deg, the glass leaning
    # 4 deg: the mean of the two walls' angles is the projected axis (the camera looks at a point on the axis), the
    # seeds (the liquid's sides) are 2 deg and 3 px off, the rows read reach far above the rim, where a box's upright
    # edge meets the left wall: the walls are read on the glass only
    frame, axis_deg, rim_y = _tapered_glass()
    seeds = []
    for side, sign in (("left", -1), ("right", 1)):
        x = np.nonzero(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)[300] < 120)[0]
        x_side = x.min() if side == "left" else x.max()
        a = math.tan(math.radians(axis_deg - sign * 4.0 + 2.0))
        seeds.append(EdgeLine(a, x_side + 3 - a * 300, 260, 380, 0.0, 0))
    walls = glass_walls(frame, seeds, (40, 370))
    assert len(walls) == 2
    lines = [[f for f, _ in faces] for faces in walls]
    angles = [np.mean([f.angle_deg for f in faces]) for faces in lines]
    assert abs(np.mean(angles) - axis_deg) < 0.05, (angles, axis_deg)
    assert abs(angles[0] - angles[1]) > 6  # the taper is measured, not averaged away per wall
    assert min(f.y0 for faces in lines for f in faces) > rim_y - 10  # nothing above the rim
    # followed in the next frame from these lines: the same walls
    again = glass_walls(frame, seeds, (40, 370), walls)
    again_angles = [np.mean([f.angle_deg for f, _ in faces]) for faces in again]
    assert np.allclose(again_angles, angles, atol=0.02)


def test_a_still_containers_noisy_walls_read_as_one_angle_and_a_moving_ones_do_not():
    # walls measured in every frame of a path-traced tumbler decay scattered by 0.3 deg about 6.4 deg (the picture's
    # noise kept them from being held), which added that scatter to the liquid's angle against them; white noise
    # scatters about its median as much as its frame-to-frame noise says (ratio 1), any motion far more
    rng = np.random.default_rng(11)
    t = np.arange(120) / 30.0
    valid = np.ones(t.size, bool)
    noise = rng.normal(0.0, 0.3, t.size)
    assert steady_angle(6.4 + noise, valid) == pytest.approx(6.4, abs=0.1)  # the median of 120: 0.03 deg scatter
    assert steady_angle(6.4 + noise + 2.0 * np.sin(2 * np.pi * 0.5 * t), valid) is None  # a 2 deg robot tilt
    assert steady_angle(6.4 + noise + 0.5 * t, valid) is None  # a slow 2 deg turn over the clip
    held = np.repeat(6.4 + noise[::6], 6)  # walls held between measurements: consecutive frames repeat
    assert steady_angle(held, valid) is None
    assert steady_angle(6.4 + noise[:19], valid[:19]) is None  # too few frames to tell


def test_a_container_turned_in_fewer_than_half_its_frames_is_not_still():
    # the walls' angles (deg) of the real frame swung by 4 deg at 1 Hz after half a second (960 px, H.264 CRF 20), as
    # the tracker measured them: the still frames outnumber the moving ones, so the robust scatter of the angles and
    # that of their steps were alike (0.119 and 0.116 deg) and the container was taken for still (the moving frames
    # were then read in the still ones' axes: a 3.4 deg slosh that was the turn). Their running median leaves the
    # median by 3.8 deg. Two misread frames of a still container (a meniscus, 1 deg) do not make it move
    swung = [0.219, 0.225, 0.234, 0.243, 0.25, 0.25, 0.237, 0.237, 0.22, 0.216, 0.222, 0.229, 0.234, 0.234, 0.234]
    swung += [0.123, 1.181, 1.795, 2.55, 3.181, 3.722, 3.969, 4.273, 4.162, 4.042, 3.657, 3.197, 2.617, 1.905, 1.213]
    valid = np.ones(len(swung), bool)
    assert steady_angle(np.array(swung), valid) is None
    misread = 0.2 + np.random.default_rng(12).normal(0.0, 0.03, len(swung))
    misread[[8, 21]] += 1.0
    assert steady_angle(misread, valid) == pytest.approx(0.2, abs=0.03)


def test_walls_read_to_thousandths_that_drift_with_the_slosh_are_a_still_container():
    # a Blender tap decay's walls, read in every frame: the first -5.86 deg, then -3.64 to -3.66 drifting 0.02 deg
    # with the slosh against a frame-to-frame noise of 0.002 deg (their scatter 5 noises): refused as moving, so the
    # first frame's 2.2 deg went into the relative angle. Within STEADY_FLOOR_DEG of their median they are still;
    # a 0.5 deg turn over the clip is not, however small the noise
    t = np.arange(48) / 30.0
    valid = np.ones(t.size, bool)
    walls = -3.65 + 0.01 * np.sin(2 * np.pi * 0.5 * t) + np.random.default_rng(13).normal(0.0, 0.002, t.size)
    walls[0] = -5.86
    assert steady_angle(walls, valid) is None  # the noise alone says it moved
    assert steady_angle(walls, valid, STEADY_FLOOR_DEG) == pytest.approx(-3.65, abs=0.01)
    assert steady_angle(walls + 0.5 * t / t[-1], valid, STEADY_FLOOR_DEG) is None


def _outline_line(project, radius: float, side: int) -> tuple[float, float]:
    """The glass's outline on one side (-1 left, +1 right) between 10 and 60 mm up as x = a y + b: the outermost
    points of two of its rings as the camera draws them."""
    th = np.linspace(-math.pi, math.pi, 7200)
    ends = []
    for z in (0.01, 0.06):
        p = project(np.column_stack([radius * np.cos(th), radius * np.sin(th), np.full_like(th, z)]))
        ends.append(p[np.argmax(side * p[:, 0])])
    (x0, y0), (x1, y1) = ends
    a = (x1 - x0) / (y1 - y0)
    return a, x0 - a * y0


def test_of_two_faces_that_are_not_parallel_the_one_along_the_liquids_side_counts():
    # a dark pole stands behind the glass's right wall, turned 8 deg from it: its edge runs beside the wall's face over
    # the whole height, of the other polarity, and was taken for the wall's second face (the axis 1.18 deg off); a
    # glass's two faces are parallel, so of two more than FACE_AGREE_DEG apart (3.5 deg here) the one nearer the
    # liquid's side in direction is kept: within 0.4 deg of the axis (the face kept reads 0.6 deg off beside the pole)
    project = _camera(3.0, 8.0, 1.0)
    img = np.full((480 * SS, 640 * SS), 200, np.uint8)
    (xt, yt), (xb, yb) = project([[0.033, 0, 0.1], [0.033, 0, 0.0]])
    xm, ym, t = 0.5 * (xt + xb) + 3.0, 0.5 * (yt + yb), math.radians(8.0)
    half = np.array([200 * math.sin(t), 200 * math.cos(t)])
    centre = np.array([xm, ym])
    along = np.array([centre - half, centre + half])
    pole = np.vstack([along, along[::-1] + np.array([60.0, 0.0])])
    cv2.fillConvexPoly(img, ((pole + 0.5) * SS).astype(np.int32), 120)
    _solid(project, lambda z: 0.033, 0.0, 0.1, 160, img)  # the glass, outer face
    _solid(project, lambda z: 0.030, 0.0, 0.1, 185, img)  # the empty glass inside
    _solid(project, lambda z: 0.030, 0.0, 0.066, 70, img)  # the liquid
    grey = cv2.resize(img, (640, 480), interpolation=cv2.INTER_AREA).astype(np.float32)
    grey += np.random.default_rng(3).normal(0.0, 2.0, grey.shape)
    frame = cv2.cvtColor(np.clip(grey, 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
    (x0, y0), (x1, y1), (_, level) = project([[0, 0, 0.0], [0, 0, 0.066], [0, 0, 0.066]])
    axis_deg = math.degrees(math.atan((x1 - x0) / (y1 - y0)))
    top = int(level)
    seeds = [EdgeLine(*_outline_line(project, 0.030, side), top + 2, top + 90, 0.0, 0) for side in (-1, 1)]
    walls = glass_walls(frame, seeds, (top - 100, top + 90), sides=True)
    assert [len(faces) for faces in walls] == [1, 1]
    mean = np.mean([f.angle_deg for faces in walls for f, _ in faces])
    assert abs(mean - axis_deg) < 0.4, (mean, axis_deg)


def test_walls_away_from_the_liquids_sides_are_not_the_containers():
    # a held-out path-traced beaker before clutter: Hough's nearest near-vertical line was a box's edge 76 px right of
    # the liquid's right side, and none on the left; that one line was followed as the container (4.6 deg off). Walls
    # are the container's only where each of the liquid's sides has an edge within 12 % of the width between them
    sides = [EdgeLine(0.0984, 180.5, 184, 318, 0.0, 0), EdgeLine(0.1064, 410.6, 164, 320, 0.0, 0)]
    box_edge = EdgeLine(0.0341, 503.9, 38, 394, 0.3, 227)
    assert not beside_sides([box_edge], sides)
    glass = [EdgeLine(0.0991, 180.3, 183, 319, 0.0, 136), EdgeLine(0.1064, 410.5, 136, 319, 0.0, 183)]
    assert beside_sides(glass, sides)
    assert not beside_sides(glass[:1], sides)  # one side only
    outer = [EdgeLine(0.0991, 180.3 - 20, 183, 319, 0.0, 136), glass[1]]  # 20 px out: a glass's outer face
    assert beside_sides(outer, sides)


def test_a_wall_held_by_a_box_behind_the_glass_is_let_go_as_the_glass_moves_on(tmp_path):
    # a glass of blue dye carried to the right past a violet box behind it, whose edge (leaning 1.5 deg) stands just
    # left of the glass's left wall at first: the followed wall held the box's edge as the glass went on (pbr cross80:
    # for 40 frames, then both walls ran off the other way, the container 9 deg off), reading the container 0.11-0.25
    # deg off here; the walls keep their place beside the liquid's sides, so once the glass has moved on from the box
    # (by frame 10) the wall is found again on the glass: within 0.1 deg
    width, height, frames = 400, 300, 30
    camera = _camera(0.0, 8.0, 0.0)

    def placed(k: int):
        """The camera's projection of the glass carried k frames on, 1.2 mm a frame."""
        shift = np.array([-0.045 + 0.0012 * k, 0.0, 0.0])
        return lambda p: camera(np.asarray(p, float) + shift) - [120.0, 90.0]

    edge = placed(0)([[-0.033, 0, 0.05]])[0, 0] - 3
    lean = math.tan(math.radians(-1.5))
    box = np.array([[0, 0], [edge + 150 * lean, 0], [edge - 150 * lean, height], [0, height]])
    rng = np.random.default_rng(4)
    axis = []
    path = tmp_path / "past_a_box.mp4"
    with VideoWriter(path, width, height, 30.0, "h264", 18) as writer:
        for k in range(frames):
            project = placed(k)
            img = np.full((height * SS, width * SS, 3), 200, np.uint8)
            cv2.fillConvexPoly(img, ((box + 0.5) * SS).astype(np.int32), (140, 60, 150))
            _solid(project, lambda z: 0.033, 0.0, 0.1, (175, 175, 175), img)  # the glass, outer face
            _solid(project, lambda z: 0.030, 0.0, 0.1, (190, 190, 190), img)  # the empty glass inside
            _solid(project, lambda z: 0.030, 0.0, 0.066, (200, 90, 20), img)  # the liquid
            picture = cv2.resize(img, (width, height), interpolation=cv2.INTER_AREA).astype(np.float32)
            picture += rng.normal(0.0, 2.0, picture.shape)
            writer.write(np.clip(picture, 0, 255).astype(np.uint8), k / 30)
            (x0, y0), (x1, y1) = project([[0, 0, 0.0], [0, 0, 0.066]])
            axis.append(math.degrees(math.atan((x1 - x0) / (y1 - y0))))
    res = track_video(path, TrackSettings(target="surface", reference="container", liquid_color="blue"))
    err = np.abs(res.columns()["container_angle_deg"] - np.array(axis))[15:]
    assert res.valid.all()
    assert np.median(err) < 0.1 and err.max() < 0.2, np.round(err, 2)


@pytest.mark.parametrize("stale_px", [6.0, 8.0, -8.0, 12.0])
def test_walls_found_afresh_are_sought_where_their_hough_lines_lie(stale_px):
    # walls lost on a moving container are found again by Hough and refitted row by row about those lines; the refit
    # had placed its search at the lost walls' last motion per frame (up to 12.8 px in the Blender moves, beyond the
    # 9 px band): the walls were not found, or another edge was (2.1 deg instead of 2.8 here). Whatever that motion,
    # the walls are those found with none, and no motion is carried on
    frame, _, rim = _tapered_glass(lean_deg=0.0)
    grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    ys, xs = np.nonzero(grey < 120)
    ys, xs = ys[ys > rim + 20], xs[ys > rim + 20]  # the liquid
    here = (float(xs.mean()), float(ys.mean()), 0.8 * float(xs.max() - xs.min()))
    still, moving = ContainerTracker((0, 0, 640, 480)), ContainerTracker((0, 0, 640, 480))
    want, _ = still._measure(frame, *here)
    moving._shift = stale_px
    got, anew = moving._measure(frame, *here)
    assert want.found and got.found and anew
    assert got.angle_deg == pytest.approx(want.angle_deg, abs=1e-9)
    assert moving._shift == 0.0
