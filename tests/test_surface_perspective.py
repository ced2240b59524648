"""The perspective of a camera above the liquid and a container off the picture's centre (issue 37): a pinhole
camera's picture of a tilted surface's contact line, fitted as the surface tracker fits it (`_fit_front` across the
ellipse's ends as seen), misses the truth's line (the container's plane parallel to the picture) by sin(e) tan(psi);
`perspective_deg` with the camera's field of view gives it back, to a few per cent of the effect."""

import math

import numpy as np
import pytest

from sloshid.core.errors import UserError
from sloshid.tracking.surface import _fit_front
from sloshid.tracking.surface_track import USUAL_FOV_DEG, _moved_at, lens_from_rest, perspective_deg, perspective_notes
from sloshid.tracking.tracker import TrackSettings

WIDTH, HEIGHT, FOCAL = 640, 480, 400.0
R, D = 0.035, 0.35


def picture(offset_m: float, elevation_deg: float, tilt_deg: float):
    """Pixels of the contact line (angles from the front, toward +x) and of the mid-plane's ends for a pinhole camera
    `elevation_deg` above the surface's centre at distance D, the container `offset_m` to the right of it."""
    e = math.radians(elevation_deg)
    C = np.array([0.0, -D * math.cos(e), D * math.sin(e)])
    ahead = -C / np.linalg.norm(C)
    right = np.cross(ahead, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(ahead, right)
    a = math.tan(math.radians(tilt_deg))

    def project(p):
        q = p - C
        depth = q @ ahead
        return np.column_stack(
            [(WIDTH - 1) / 2 + FOCAL * (q @ right) / depth, (HEIGHT - 1) / 2 + FOCAL * (q @ down) / depth]
        )

    theta = np.linspace(-math.pi, math.pi, 20001)
    ring = np.column_stack([R * np.sin(theta) + offset_m, -R * np.cos(theta), a * R * np.sin(theta)])
    ends = np.array([[offset_m - R, 0.0, -a * R], [offset_m + R, 0.0, a * R]])
    return theta, project(ring), project(ends)


def tracked(theta, px):
    """The line's angle (deg, counter-clockwise) and k / R fitted as the tracker fits the front edge: s across the
    ellipse's ends as seen, w up; and the ends' centre column."""
    left, right = int(np.argmin(px[:, 0])), int(np.argmax(px[:, 0]))
    uc, half = 0.5 * (px[left, 0] + px[right, 0]), 0.5 * (px[right, 0] - px[left, 0])
    front = (theta > theta[left]) & (theta < theta[right])  # from one grazing point to the other through the front
    s = (px[front, 0] - uc) / half
    keep = np.abs(s) <= 0.88  # the tracker leaves out the columns next to the walls
    (_, c1, c3, k, _), _, rms = _fit_front(s[keep], -px[front, 1][keep], 10)
    assert rms < 0.05
    return math.degrees(math.atan((c1 + 0.6 * c3) / half)), k / half, uc


@pytest.mark.parametrize("offset_m", [-0.06, 0.03, 0.06])
@pytest.mark.parametrize("tilt_deg", [0.0, 4.0])
def test_the_field_of_view_gives_the_line_back(offset_m, tilt_deg):
    theta, px, ends = picture(offset_m, 12.0, tilt_deg)
    truth = math.degrees(math.atan2(-(ends[1, 1] - ends[0, 1]), ends[1, 0] - ends[0, 0]))
    seen, sin_e, centre = tracked(theta, px)
    fov = math.degrees(2 * math.atan(WIDTH / 2 / FOCAL))
    missed = truth - seen
    assert abs(missed) > 0.3  # the effect is there (a degree at the widest offset)
    # what is left is under 5 % of it (the fitted k / R and tan(psi) for psi are first-order)
    assert seen + perspective_deg(centre, WIDTH, sin_e, fov) == pytest.approx(truth, abs=0.05 * abs(missed))


def test_a_centred_container_needs_no_correction():
    theta, px, ends = picture(0.0, 12.0, 4.0)
    truth = math.degrees(math.atan2(-(ends[1, 1] - ends[0, 1]), ends[1, 0] - ends[0, 0]))
    seen, sin_e, centre = tracked(theta, px)
    assert seen == pytest.approx(truth, abs=0.02)
    assert abs(perspective_deg(centre, WIDTH, sin_e, 60.0)) < 0.01


def test_field_of_view_is_checked():
    with pytest.raises(UserError, match="fov_deg"):
        TrackSettings(target="surface", fov_deg=200.0)
    with pytest.raises(UserError, match="fov_deg"):
        TrackSettings(target="float", fov_deg=60.0)


def test_fov_on_the_command_line(tmp_path, run_cli):
    code, _, err = run_cli(
        "track", tmp_path / "none.mp4", "-o", tmp_path / "a.csv", "--target", "surface", "--fov-deg", "200"
    )
    assert code == 2 and "--fov-deg must be between 0 and 180 degrees" in err


def test_a_perspective_that_matters_is_named_when_no_field_of_view_is_given():
    # seen from 12 deg above, a container 40 px off the centre of a 400 px picture turns the line by 1.7 deg with a
    # usual lens: the warning says by how much (as perspective_deg gives it) and what to give; a centred container,
    # or one seen from the side, gets none (under 0.1 deg)
    sin_e = math.sin(math.radians(12.0))
    x = np.array([159.5, 199.5, 239.5])
    (note,) = perspective_notes(x, 400, sin_e)
    turn = perspective_deg(x, 400, sin_e, USUAL_FOV_DEG)
    assert f"{turn.min():+.2f} to {turn.max():+.2f} deg" in note and "`fov_deg`" in note
    assert abs(turn.max() - 1.66) < 0.01  # 0.208 x 40 / 286 rad
    assert perspective_notes(np.array([199.0, 200.0]), 400, sin_e) == []
    assert perspective_notes(x, 400, math.sin(math.radians(0.3))) == []


def moved_between(places: list[tuple[float, float]], frames: tuple[int, ...], turning_deg: float = 0.0):
    """A track's arrays for a container that rests at the first place, is carried (frames in between, not valid) and
    rests at the second: each place's (offset_m, tilt_deg) pictured and fitted as `tracked` does, the walls upright
    (turning by `turning_deg` over the second rest: a container still tilting)."""
    n_a, n_move, n_b = frames
    x, line, half, sin_e = [], [], [], []
    for offset, tilt in places:
        theta, px, _ = picture(offset, 12.0, tilt)
        seen, k, centre = tracked(theta, px)
        x.append(centre), line.append(seen), sin_e.append(abs(k))
        half.append(0.5 * (px[:, 0].max() - px[:, 0].min()))
    n = n_a + n_move + n_b
    idx = np.r_[np.zeros(n_a, int), np.zeros(n_move, int), np.ones(n_b, int)]
    xs, lines, widths = np.array(x)[idx], np.array(line)[idx], 2 * np.array(half)[idx]
    xs[n_a : n_a + n_move] = np.linspace(x[0], x[1], n_move)  # carried across the picture
    valid = np.ones(n, bool)
    cang = np.r_[np.zeros(n_a + n_move), np.linspace(0.0, turning_deg, n_b)]
    ys = np.full(n, 240.0)
    return xs, ys, lines, cang, valid, widths, _moved_at(valid, xs, ys, widths), float(np.mean(sin_e))


def test_the_lens_is_found_where_the_liquid_rests_before_and_after_a_move():
    # the liquid at rest is level at both places, so the line's difference there is the camera's: the field of view
    # found is the picture's (77.3 deg), to the first-order perspective_deg's few per cent, and it corrects a tilted
    # surface elsewhere in the picture as the true one does (within 5 % of the effect, as above)
    x, y, line, cang, valid, width, moved, sin_e = moved_between([(-0.06, 0.0), (0.06, 0.0)], (10, 15, 12))
    fov = lens_from_rest(x, y, line, cang, valid, width, moved, WIDTH, sin_e)
    true_fov = math.degrees(2 * math.atan(WIDTH / 2 / FOCAL))
    assert fov == pytest.approx(true_fov, rel=0.05)
    theta, px, ends = picture(0.03, 12.0, 4.0)
    truth = math.degrees(math.atan2(-(ends[1, 1] - ends[0, 1]), ends[1, 0] - ends[0, 0]))
    seen, _, centre = tracked(theta, px)
    assert seen + perspective_deg(centre, WIDTH, sin_e, fov) == pytest.approx(truth, abs=0.05 * abs(truth - seen))


def test_a_tilt_that_ends_after_the_move_leaves_the_rest_after_it():
    # a robot tilts the container back upright after it came back (its walls turn by 2 deg in the first 5 frames of
    # the rest after the move) and starts tilting it before the centre leaves (the last 3 frames before the move): the
    # rest places are cut to their parts away from the move, whose liquid is level, and the lens found is the
    # picture's (to perspective_deg's few per cent, as above)
    x, y, line, cang, valid, width, moved, sin_e = moved_between([(-0.06, 0.0), (0.06, 0.0)], (10, 15, 14))
    cang[25:30] = np.linspace(2.0, 0.4, 5)
    cang[7:10] = [0.3, 0.7, 1.2]
    fov = lens_from_rest(x, y, line, cang, valid, width, moved, WIDTH, sin_e)
    assert fov == pytest.approx(math.degrees(2 * math.atan(WIDTH / 2 / FOCAL)), rel=0.05)
    # too few still frames left (the tilt ends in the rest's last 3 frames): none
    cang[25:36] = np.linspace(2.0, 0.4, 11)
    assert lens_from_rest(x, y, line, cang, valid, width, moved, WIDTH, sin_e) is None


def test_no_lens_without_two_rest_places():
    # still tilting after the move (the walls turned by a degree): its liquid is not level there
    args = moved_between([(-0.06, 0.0), (0.06, 0.0)], (10, 15, 12), turning_deg=2.0)
    assert lens_from_rest(*args[:-1], WIDTH, args[-1]) is None
    # too short a rest before or after the move (a period of a ringing not seen)
    for frames in ((10, 15, 5), (5, 15, 12)):
        args = moved_between([(-0.06, 0.0), (0.06, 0.0)], frames)
        assert lens_from_rest(*args[:-1], WIDTH, args[-1]) is None
    # the liquid reads the same angle at both places (no perspective: a camera level with it, or a painted clip)
    x, y, line, cang, valid, width, moved, sin_e = moved_between([(-0.06, 0.0), (0.06, 0.0)], (10, 15, 12))
    assert lens_from_rest(x, y, np.zeros_like(line), cang, valid, width, moved, WIDTH, sin_e) is None
    # the container moved too little across the picture for the difference to tell the lens
    args = moved_between([(-0.01, 0.0), (0.01, 0.0)], (10, 15, 12))
    assert lens_from_rest(*args[:-1], WIDTH, args[-1]) is None
