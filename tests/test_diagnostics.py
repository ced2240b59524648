"""How sloshid speaks to its users: doubts as SloshidWarnings (and in the result's `warnings`), progress through
`logging`, settings named as the library knows them and re-worded by the command line as the options typed there."""

from __future__ import annotations

import logging
import warnings

import pytest

from sloshid.core.errors import SloshidWarning, rename_settings
from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.tracking.tracker import TrackSettings, track_video

STILL = dict(width=320, height=240, fps=30.0, duration_s=1.0, amplitude_deg=0.0, quality=18)
"""A float that never moves: track warns that nothing moved it (a label of the float's colour, or a liquid at rest)."""


@pytest.fixture(scope="module")
def still_clip(tmp_path_factory):
    path = tmp_path_factory.mktemp("still") / "still.mp4"
    render_video(path, SynthSettings(**STILL))
    return path


def test_a_doubt_is_a_sloshid_warning_and_stays_on_the_result(still_clip, caplog):
    with pytest.warns(SloshidWarning, match="nothing moved it") as caught, caplog.at_level(logging.INFO, "sloshid"):
        res = track_video(still_clip, TrackSettings(smooth=False), multithreaded=False)
    assert [str(w.message) for w in caught if w.category is SloshidWarning] == res.warnings
    assert res.still  # what the command line's next step reads
    assert issubclass(SloshidWarning, UserWarning)
    # a notebook can silence them by category, and read the progress from the package's logger
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", SloshidWarning)
        track_video(still_clip, TrackSettings(smooth=False), multithreaded=False)
    assert any(r.name == "sloshid.tracking" and "tracked" in r.getMessage() for r in caplog.records)


def test_the_command_line_prints_each_warning_once_with_its_options(still_clip, tmp_path, run_cli):
    code, _, err = run_cli("track", still_clip, "-o", tmp_path / "a.csv", "--no-smooth")
    assert code == 0
    lines = [line for line in err.splitlines() if "nothing moved it" in line]
    assert len(lines) == 1 and lines[0].startswith("sloshid: warning: ")  # not repeated by Python's warnings
    assert "check with --overlay, or narrow --roi" in lines[0] and "`" not in lines[0]  # the options typed there


def test_track_does_not_send_a_trace_where_nothing_moved_on_to_identify(still_clip, tmp_path, run_cli):
    # it warned "nothing moved it", then printed `next: sloshid identify ...`, which found no oscillatory mode
    code, out, _ = run_cli("track", still_clip, "-o", tmp_path / "a.csv", "--no-smooth")
    step = out.strip().splitlines()[-1]
    assert code == 0 and "sloshid identify" not in step
    assert step.startswith("next: nothing moved the float, so identify would find no mode: record a tap")
    assert "check what was tracked with --overlay OUT.mp4, then track again." in step


def test_a_setting_in_backticks_is_renamed_and_an_unknown_one_kept():
    rename = {"window_s": "--window"}.get
    text = "give a longer window (`window_s`), or check `sloshid track` and `other_setting`"
    assert (
        rename_settings(text, rename) == "give a longer window (--window), or check `sloshid track` and `other_setting`"
    )
