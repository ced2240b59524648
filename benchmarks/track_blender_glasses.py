"""Benchmark: glasses rendered by an independent renderer (Blender's Cycles), turned and tracked with no option.

Issue 37's outside check scored the tracker on renders of a renderer nobody here wrote. sloshid's own physically based
renderer (Mitsuba 3, `synth --renderer pbr`) and the scenes it draws are what the tracker was tuned on; this set comes
from Blender's Cycles with a scene built apart (`blender_glasses_scene.py`: its own glass and liquid meshes, shaders,
lights, camera and truth), so that it fails where the tracker fits sloshid's renderer rather than light. 24 glasses at
rest (a straight or tapered glass with a thick bottom; orange and red juice, cola, and red, orange and blue dyes; half
of them leaning up to 5 deg; the camera 0-15 deg above the surface and rolled up to 3 deg), 640x480, 48 samples per
pixel, denoised. Each picture is turned as the outside check turned its photos (0, +5, -7 deg, `still_clip`, 45
frames, sensor noise 3, H.264 CRF 20) and tracked with `--target surface` and no other option, against the image and
the container; the unturned clip is also given to `sloshid inspect` (its command is run) and tracked with an ROI on the
glass's outline and 3 % inside it. Two sets of 24 from other seeds: the development set (seeds 1200 on,
data/blender_glasses/), whose first run was recorded before anything was changed for it, and the held-out set
(--holdout: seeds 1300 on, data/blender_glasses_holdout/), which nothing is changed for. Writes
reports/benchmarks/track_blender_glasses{,_holdout}.{json,md}. With --clips: two free decays of development glasses
(the surface a plane released at 5 deg, data/blender_clips/) and four robot moves of held-out glasses (carried across
the picture and tilted, data/blender_moves/), tracked and scored for gain, lag, wall heights, f and zeta, into
reports/benchmarks/track_blender_clips.{json,md} (rendering them takes about 30 min).

Rendering needs `bpy`, which pins its own NumPy: install it in a venv of its own and name its Python, e.g.
python3 -m venv .venv-blender && .venv-blender/bin/pip install bpy, then, from the repository root,
.venv/bin/python benchmarks/track_blender_glasses.py --blender-python .venv-blender/bin/python (rendering takes
about 25 min a set on one core the first time; the pictures are kept).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench_output import ROOT, write_results
from track_pbr import _identified, gain_lag, wall_rmse_px
from track_real_variants import inspect_row
from track_table_glasses import group_table, turned_row

from sloshid.core.errors import UserError
from sloshid.identification.signals import Signal, signal_from_track
from sloshid.tracking.tracker import TrackSettings, track_video
from sloshid.video.frames import VideoWriter

SETS = {"dev": (ROOT / "data" / "blender_glasses", 1200), "holdout": (ROOT / "data" / "blender_glasses_holdout", 1300)}
"""The set the tracker may be changed on (its first run recorded before), and the set from other seeds it never is."""
SCENES = 24
SCENE_SCRIPT = Path(__file__).with_name("blender_glasses_scene.py")
CLIPS = ROOT / "data" / "blender_clips"
CLIP_CASES = {"decay_a": (1206, 3.0, 0.05), "decay_b": (1207, 3.4, 0.07)}
"""Free decays (scene seed, f, zeta) of two development glasses: 48 frames at 30 fps, released at 5 deg."""
MOVES = ROOT / "data" / "blender_moves"
MOVE_CASES = {
    "move_a": (1400, 0.09, 12.0),
    "move_b": (1411, 0.09, -12.0),
    "move_c": (1404, 0.09, 12.0),
    "move_d": (1413, 0.09, -12.0),
    "move_e": (1430, 0.12, 8.0),
    "move_f": (1431, -0.09, -12.0),
    "move_g": (1432, 0.06, 15.0),
    "move_h": (1433, -0.12, 10.0),
}
"""Robot moves (scene seed, travel m, tilt deg) of glasses from seeds no set uses: 60 frames at 30 fps, zeta 0.02;
move_c and move_d rendered after the rest-window fix, which they check; move_e to move_h after the rest places cut
to their still parts (2026-12-07), with other travels, both directions and other tilts, which they check."""


def need_bpy(blender_python: str, what: str) -> None:
    """Stop with one sentence when `blender_python` cannot import bpy, which renders `what`."""
    try:
        missing = subprocess.run([blender_python, "-c", "import bpy"], capture_output=True).returncode != 0
    except OSError:  # no such interpreter
        missing = True
    if missing:
        sys.exit(
            f"{blender_python} cannot import bpy, which renders {what}: install it in a venv of its own "
            "(python3 -m venv .venv-blender && .venv-blender/bin/pip install bpy) and give "
            "--blender-python .venv-blender/bin/python."
        )


def render(blender_python: str, folder: Path, first_seed: int) -> None:
    """Render the scenes missing from `folder` (seeds from `first_seed`) with `blender_python` (a Python with bpy)."""
    missing = [i for i in range(SCENES) if not (folder / f"glass{i:02d}.json").is_file()]
    if not missing:
        return
    need_bpy(blender_python, f"the {len(missing)} missing scenes")
    print(f"rendering {len(missing)} scenes with Cycles into {folder} (about a minute each)")
    subprocess.run([blender_python, str(SCENE_SCRIPT), str(folder), str(SCENES), str(first_seed)], check=True)


def clip_rows(blender_python: str) -> list[dict]:
    """Render the missing decays and moves, code each as H.264 (noise 3, CRF 20), track it with no option against the
    image and the container, and score it: RMSE, gain and lag, wall heights where the truth has them, and for a decay
    f and zeta identified from the tracked trace against the truth's."""
    cases = {
        name: (CLIPS / name, ["--clip", str(seed), "48", "30", "5", str(f), str(z)])
        for name, (seed, f, z) in CLIP_CASES.items()
    }
    cases |= {
        name: (MOVES / name, ["--move", str(seed), "60", "30", str(travel), str(tilt), "0.02"])
        for name, (seed, travel, tilt) in MOVE_CASES.items()
    }
    rows = []
    for name, (folder, args) in cases.items():
        if not (folder / "truth.json").is_file():
            need_bpy(blender_python, f"the clip {name}")
            subprocess.run([blender_python, str(SCENE_SCRIPT), args[0], str(folder), *args[1:]], check=True)
        record = json.loads((folder / "truth.json").read_text())
        keys = ("t_s", "surface_angle_deg", "rel_angle_deg", "left_wall_px", "right_wall_px")
        truth = {k: np.array([r[k] for r in record["rows"]]) for k in keys if k in record["rows"][0]}
        rng = np.random.default_rng(5)
        with tempfile.TemporaryDirectory() as tmp:
            video = Path(tmp) / f"{name}.mp4"
            first = cv2.imread(str(folder / "frame_0000.png"))
            with VideoWriter(video, first.shape[1], first.shape[0], 30.0, "h264", 20) as writer:
                for k, t in enumerate(truth["t_s"]):
                    frame = cv2.imread(str(folder / f"frame_{k:04d}.png")).astype(np.float32)
                    frame += rng.normal(0.0, 3.0, frame.shape).astype(np.float32)
                    writer.write(np.clip(frame, 0, 255).astype(np.uint8), float(t))
            row: dict = {
                "case": name,
                "scene": record["scene"]["liquid"],
                "f_hz": record["f_hz"],
                "zeta": record["zeta"],
            }
            for reference, key in (("image", "surface_angle_deg"), ("container", "rel_angle_deg")):
                try:
                    res = track_video(video, TrackSettings(target="surface", reference=reference))
                except UserError as e:
                    row[reference] = {"tracked": False, "refusal": str(e)}
                    continue
                ok = res.valid.astype(bool)[: len(truth["t_s"])]
                want = truth[key][: len(ok)]
                err = res.angle_deg[: len(ok)][ok] - want[ok]
                gain, lag = gain_lag(res.t_s[: len(ok)][ok], res.angle_deg[: len(ok)][ok], want[ok])
                out = {"tracked": bool(ok.mean() >= 0.8), "valid_share": float(ok.mean()), "gain": gain, "lag_s": lag}
                out["rmse_deg"] = float(np.sqrt(np.mean(err**2)))
                if "left_wall_px" in truth:
                    out["wall_rmse_px"] = wall_rmse_px(res.columns(), truth, ok)
                if name in CLIP_CASES:
                    tracked = _identified(lambda res=res: signal_from_track(res))
                    signal = Signal(truth["t_s"], truth[key], "angle", "deg", "truth")
                    exact = _identified(lambda signal=signal: signal)
                    if tracked and exact:
                        for k, label in (("f_hz", "f"), ("zeta", "zeta")):
                            out[f"{label}_err_pct"] = 100 * (tracked[k][0] / exact[k][0] - 1)
                            out[f"{label}_covered"] = bool(tracked[k][1] <= exact[k][0] <= tracked[k][2])
                row[reference] = out
            row["inspect"] = inspect_row(video)
        print(name, {k: v for k, v in row.items() if k in ("image", "container")}, flush=True)
        rows.append(row)
    return rows


def clips_report(rows: list[dict]) -> None:
    """The decays' table and notes."""
    table = []
    for r in rows:
        for ref in ("image", "container"):
            o = r[ref]
            look = f"{100 * r['inspect']['valid_share']:.0f} %" if ref == "image" and "inspect" in r else ""
            if not o.get("valid_share"):
                table.append([r["case"], r["scene"], ref, "refused", "-", "-", "-", "-", "-", "-", look])
                continue
            table.append(
                [
                    r["case"],
                    r["scene"],
                    ref,
                    f"{100 * o['valid_share']:.0f} %",
                    f"{o['rmse_deg']:.3g}",
                    f"{o['gain']:.3f}",
                    f"{1000 * o['lag_s']:.0f}",
                    f"{o['wall_rmse_px']:.2f}" if "wall_rmse_px" in o else "-",
                    "-" if "f_err_pct" not in o else f"{o['f_err_pct']:+.2f} ({'in' if o['f_covered'] else 'out'})",
                    "-"
                    if "zeta_err_pct" not in o
                    else f"{o['zeta_err_pct']:+.1f} ({'in' if o['zeta_covered'] else 'out'})",
                    look,
                ]
            )
    header = ["clip", "liquid", "reference", "frames valid", "RMSE, deg", "gain", "lag, ms", "wall RMSE, px"]
    header += ["f err, %", "zeta err, %", "inspect's command: frames valid"]
    notes = (
        "Free decays rendered by Blender's Cycles (`blender_glasses_scene.py --clip`): the development set's glass06 "
        "(a straight glass of red dye seen 8.8 deg from above; f 3.0 Hz, zeta 0.05) and glass07 (a tumbler of orange "
        "juice leaning 1.2 deg, 6.7 deg from above; 3.4 Hz, 0.07), the surface a plane released at 5 deg about the "
        "line of sight, 48 frames at 30 fps (1.6 s), 400x300 at 16 samples per pixel, denoised; coded with sensor "
        "noise 3 at H.264 CRF 20 and tracked with no option. Gain and lag: the tracked angle regressed on the truth "
        "at the best lag (track_pbr's `gain_lag`); f and zeta: identified from the tracked trace as `sloshid identify` "
        "reads a track, against the truth trace's, with whether the tracked 95 % interval holds it. Issue 37's "
        "targets: gain 1 +- 0.02, f within 0.3 %, zeta within 5 %. Tracked once; nothing changed for them. "
        "Robot moves (`blender_glasses_scene.py --move`, held out: scenes of seeds 1400, 1411, 1404 and 1413, which no "
        "other set draws, rendered 2026-12-06 after the decays and read once, again 2026-12-07 in a fresh install and "
        "that evening in another (Cycles' pictures differ from machine to machine: move_c 65 -> 52 % of its frames "
        "valid, move_h 77 -> 82 %, move_d's RMSE 0.80 -> 0.85 deg, the tracker unchanged); "
        "move_c and move_d after the rest-window fix the first two found; move_e to move_h, seeds 1430-1433, after "
        "the rest places cut to their still parts, which move_c found): move_a a tumbler of red dye seen 6.6 deg "
        "from above, move_b a straight glass of orange juice seen 10 deg from above, move_c a straight glass of orange "
        "dye seen 12.5 deg from above through a 20 deg lens, move_d a wide tumbler of red dye seen 6.8 deg from above, "
        "move_e a glass of blue dye seen 14 deg from above, move_f a tumbler of orange dye seen level, move_g a glass "
        "of cola seen 4.3 deg from above, move_h a tumbler of blue dye seen 4.6 deg from above; each glass, upright "
        "at rest, carried across the picture from 0.2 to 1.2 s (a minimum-jerk profile; 90 mm to the right for move_a "
        "to move_d, then 120 mm right, 90 mm left, 60 mm right and 120 mm left) while tilted about its base and back "
        "(by up to +12, -12, +12, -12, +8, -12, +15 and +10 deg), the camera still and aimed at the middle of the "
        "travel, the surface a linear pendulum at the cylinder's first mode (3.4-4.0 Hz, zeta 0.02) driven by its "
        "centre's horizontal acceleration; 60 frames at 30 fps, coded and tracked as the decays. Wall heights: the "
        "surface's height at "
        "each inner wall above the level at rest, in the glass's frame, seen in the picture (px); issue 37's target "
        "1 px RMSE. Inspect's command: `sloshid inspect` on the coded clip's first frame (which tries its command "
        "on the first 2 s beside track's own choices), and the share of all frames its command tracks validly."
    )
    write_results(
        "track_blender_clips",
        {"rows": rows},
        "Free decays and robot moves rendered by an independent renderer (Blender Cycles), tracked with no option",
        header,
        table,
        notes,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--blender-python",
        default=str(ROOT / ".venv-blender" / "bin" / "python"),
        help="a Python with bpy, for the scenes not yet rendered (default .venv-blender/bin/python)",
    )
    ap.add_argument("--holdout", action="store_true", help="the held-out set (seeds 1300 on), never tuned on")
    ap.add_argument("--clips", action="store_true", help="the free decays and robot moves instead of the stills")
    args = ap.parse_args()
    if args.clips:
        clips_report(clip_rows(args.blender_python))
        return
    folder, first_seed = SETS["holdout" if args.holdout else "dev"]
    render(args.blender_python, folder, first_seed)
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(SCENES):
            record = json.loads((folder / f"glass{i:02d}.json").read_text())
            sc = record["scene"]
            head = {
                "case": f"glass{i:02d}",
                "scene": f"{sc['shape']}, {sc['liquid']}, leaning {sc['lean_deg']:+.1f} deg",
                "elevation_deg": sc["elevation_deg"],
            }
            image = cv2.imread(str(folder / f"glass{i:02d}.png"))
            rows.append(turned_row(image, record["truth"], head, Path(tmp)))
    groups = {
        "all": rows,
        "upright": [r for r in rows if "leaning +0.0" in r["scene"]],
        "leaning": [r for r in rows if "leaning +0.0" not in r["scene"]],
        "juice (opaque)": [r for r in rows if "juice" in r["scene"]],
        "cola": [r for r in rows if "cola" in r["scene"]],
        "dye (clear)": [r for r in rows if "dye" in r["scene"]],
        "all but cola": [r for r in rows if "cola" not in r["scene"]],
    }
    figures, header, table = group_table(groups)
    notes = (
        f"{SCENES} glasses rendered by Blender's Cycles (see the script's docstring), each turned by 0, +5 and -7 deg "
        "(45 frames each) and tracked with no option; a refusal or fewer than 80 % of frames valid is not tracked. "
        "Error: the median tracked angle less the scene's truth (plus the turn, against the image); 'container': the "
        "angle relative to the container. Each unturned clip is also given to `sloshid inspect`, and the command it "
        "suggests is run, and is tracked against the image with an ROI drawn on the glass's outline and with one 3 % "
        "of its width inside it. "
        + (
            "Held out: seeds 1300 on, never tuned on; its failing cases were read once, to find the top band taken "
            "for a label (design notes, 2026-12-06). "
            if args.holdout
            else "Development set: seeds 1200 on; its first run was recorded before anything was changed for it. "
        )
        + "Cola is not a fair test here: its body renders grey (V 80-140 of 255, where a photo's is 20-60; 63 with "
        "the glass left out, so the glass adds it, more than its surfaces' reflections of the room explain); the dark "
        "preset's ceiling follows a cola up to 120 where it holds a patch of it (development glass02, V 40-100), and "
        "track takes the greyer ones as the region darker than the rest (as `inspect` gives their range of greys); "
        "the row 'all but cola' leaves it out. "
        f"Tracking took {(time.perf_counter() - t0) / 60:.1f} min."
    )
    write_results(
        "track_blender_glasses" + ("_holdout" if args.holdout else ""),
        {"figures": figures, "cases": rows},
        "Glasses rendered by an independent renderer (Blender Cycles), turned, tracked with no option"
        + (": held out" if args.holdout else ": development set"),
        header,
        table,
        notes,
    )


if __name__ == "__main__":
    main()
