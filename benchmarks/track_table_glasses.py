"""Benchmark: glasses on a table, drawn like issue 37's unseen real photos, turned and tracked with no option.

Issue 37's outside check photographed glass tumblers (straight and tapered, thick bottoms) of an orange, a near-black
and a red liquid in front of a white wall on a beige table, and tracked each photo turned by 0, +5 and -7 deg. The
corpus draws such scenes rarely: its camera looks down at most 15 deg, and a glass of cola on a table seen from
18 deg above is a usual photo. This draws 30 scenes of that kind from the physically based renderer (a straight
cylinder or a tapered tumbler, juice, cola or a strong dye of orange or red, a white wall, a beige table, the camera
2-20 deg above the surface, no roll, no lean; 960x720 at 24 samples per pixel, rendered once into
data/table_glasses/, kept), turns each picture as the outside check did (`still_clip`: sensor noise, H.264 CRF 20,
45 frames) and tracks it with `--target surface` and no other option, against the image and the container.
Error: the tracked angle against the scene's truth (plus the turn, against the image). Each unturned clip is also
given to `sloshid inspect`, and the command it suggests is run. Writes
reports/benchmarks/track_table_glasses.{json,md}. Run from the repository root:
python3 benchmarks/track_table_glasses.py (rendering takes 10-25 min the first time). With --holdout: 20 other
scenes of the same draw (seeds 900 on, data/table_glasses_holdout/), rendered after the tracker's changes of
2026-12-05 and tracked once before anything was tuned on them, into
reports/benchmarks/track_table_glasses_holdout.{json,md}. With --holdout --large: the same 20 scenes rendered at
1920x1440 (data/table_glasses_holdout_1920/; a phone's or a GoPro's picture is that large, and the tracker's pixel
thresholds were set on pictures up to 960 px), into reports/benchmarks/track_table_glasses_holdout_1920.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np
from bench_output import ROOT, write_results
from track_real_variants import inspect_tracks
from track_turned import TURNS_DEG, fmt, median_angle

from sloshid.core.atomic import write_json
from sloshid.synthetic.pbr import pbr_frames
from sloshid.synthetic.pbr_scene import PbrScene, draw_scene
from sloshid.synthetic.render import SynthSettings
from sloshid.synthetic.stills import still_clip


class Draw(NamedTuple):
    """One set of glasses: where its renders are kept, how many, the first scene seed, the random stream's salt."""

    folder: Path
    scenes: int
    first_seed: int
    salt: int
    scale: int = 1
    """The pictures are PICTURE's size times this."""


DRAWS = {
    "tuned": Draw(ROOT / "data" / "table_glasses", 30, 700, 51),
    "holdout": Draw(ROOT / "data" / "table_glasses_holdout", 20, 900, 53),
    "holdout_1920": Draw(ROOT / "data" / "table_glasses_holdout_1920", 20, 900, 53, 2),
}
"""The tuned set, the held-out one, and the held-out one's scenes rendered twice as large."""
LIQUIDS = (("juice", "orange"), ("cola", "none"), ("juice", "red"), ("strong_dye", "red"), ("strong_dye", "orange"))
"""The outside check's liquids: an orange, a near-black and a red one (juices, cola, strong dyes)."""
PICTURE = SynthSettings(
    width=960, height=720, fps=15, duration_s=0.2, amplitude_deg=0.0, renderer="pbr", spp=24, scene="surface"
)
"""One 960x720 render at 24 samples per pixel (4 spp leaves a path-traced speckle no photo has)."""
FRAMES = 45
"""Frames per clip, as in the outside check's still clips (their first frames are measured before the camera's
elevation is held, and a clip of 8 counted those twice as much as one of 45)."""
HIGH_DEG = 10.0
"""The table splits the scenes at this camera elevation."""
OUTLINE_ROIS = {"roi_outline": 0.0, "roi_inside": -0.03}
"""The unturned clips are also tracked (against the image) with an ROI drawn on the glass's outline, and with one 3 %
of its width inside it (a hand that cuts the glass's edge), as the outside check drew one tightly around the
container."""
KEYS = ("tracked_share", "err_median_deg", "err_p95_deg", "within_0.5_share")
LABELS = ("tracked", "err median, deg", "err p95, deg", "within 0.5 deg")
"""The table's figures per reference, and their column labels."""


def glass_on_table(i: int, name: str = "tuned") -> PbrScene:
    """Scene i: the corpus's draw of seed 700 + i (held out: 900 + i), made a glass of one of LIQUIDS on a beige table
    by a white wall."""
    draw = DRAWS[name]
    rng = np.random.default_rng([i, draw.salt])
    u = rng.uniform
    liquid, colour = LIQUIDS[i % len(LIQUIDS)]
    container = ("cylinder", "tumbler", "tumbler")[i % 3]
    white = u(0.85, 0.97)
    beige = u(0.6, 0.8) * np.array([1.0, 0.87, 0.68])
    return replace(
        draw_scene(draw.first_seed + i, "surface"),
        container=container,
        taper=float(u(0.08, 0.2)) if container == "tumbler" else 0.0,
        liquid=liquid,
        liquid_color=colour,
        background="plain",
        clutter=(),
        wall_rgb=(white, white, 0.98 * white),
        table_rgb=(float(beige[0]), float(beige[1]), float(beige[2])),
        bottom_m=float(u(0.008, 0.018)),
        glass_m=float(u(0.002, 0.005)),
        elevation_deg=float(u(2.0, 20.0)),
        roll_deg=0.0,
        lean_deg=0.0,
        frame_fill=float(u(0.4, 0.65)),
        noise_sigma=0.0,
    )


def outline_roi(truth: dict, share: float, shape: tuple) -> tuple[int, int, int, int]:
    """The ROI a user draws tightly around the glass: its outline (the truth's box) moved `share` of its width and
    height outward (negative: inward), inside the picture."""
    x0, y0, x1, y1 = (truth[f"box_{k}_px"] for k in ("x0", "y0", "x1", "y1"))
    dx, dy = share * (x1 - x0), share * (y1 - y0)
    X0, Y0 = max(0, int(x0 - dx)), max(0, int(y0 - dy))
    return X0, Y0, min(shape[1], math.ceil(x1 + dx)) - X0, min(shape[0], math.ceil(y1 + dy)) - Y0


def picture(i: int, name: str = "tuned") -> tuple[np.ndarray, dict]:
    """Scene i of the set `name`: its picture and its truth (rendered once, then read from the set's folder)."""
    draw = DRAWS[name]
    png, truth_json = draw.folder / f"glass{i:02d}.png", draw.folder / f"glass{i:02d}.json"
    if not (png.is_file() and truth_json.is_file()):
        sc = glass_on_table(i, name)
        size = {"width": draw.scale * PICTURE.width, "height": draw.scale * PICTURE.height}
        truth, frame = next(pbr_frames(replace(PICTURE, scene_seed=draw.first_seed + i, **size), sc))
        draw.folder.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(png), frame)
        write_json(truth_json, {"truth": {k: float(v) for k, v in truth.items()}, "scene": sc.to_dict()})
    record = json.loads(truth_json.read_text())
    return cv2.imread(str(png)), record


def case_row(
    i: int,
    folder: Path,
    name: str = "tuned",
    look: Callable[[np.ndarray], np.ndarray] | None = None,
    frames: int = FRAMES,
) -> dict:
    """Scene i (seen through `look`: a camera's processing) turned and tracked (`turned_row`)."""
    image, record = picture(i, name)
    sc = record["scene"]
    head = {
        "case": f"glass{i:02d}",
        "scene": f"{sc['container']}, {sc['liquid'].replace('_', ' ')} {sc['liquid_color']}".replace(" none", ""),
        "elevation_deg": sc["elevation_deg"],
    }
    return turned_row(image if look is None else look(image), record["truth"], head, folder, frames)


def turned_row(image: np.ndarray, truth: dict, head: dict, folder: Path, frames: int = FRAMES) -> dict:
    """A picture turned by each of TURNS_DEG in clips of `frames` frames and tracked against the image and the
    container: the errors (None: not tracked); the unturned clip also through inspect and with the outline's ROIs."""
    row = dict(head)
    for turn in TURNS_DEG:
        clip = folder / f"turn{turn:+.0f}.mp4"
        still_clip(image, clip, turn, frames=frames, seed=1)
        got = {ref: median_angle(clip, ref) for ref in ("image", "container")}
        want = {"image": truth["surface_angle_deg"] + turn, "container": truth["rel_angle_deg"]}
        row[f"{turn:+.0f}"] = {ref: None if got[ref] is None else got[ref] - want[ref] for ref in got}
        if turn == 0:
            row["inspect_tracks"] = inspect_tracks(clip)
            for name, share in OUTLINE_ROIS.items():
                got = median_angle(clip, "image", outline_roi(truth, share, image.shape))
                row[name] = None if got is None else got - want["image"]
    print(f"{row['case']} ({row['scene']}, {row['elevation_deg']:.1f} deg): {[row[f'{t:+.0f}'] for t in TURNS_DEG]}")
    return row


def summary(rows: list[dict], reference: str) -> dict:
    """Tracked share and the error's median and 95th percentile of one reference over rows."""
    errs = [r[f"{t:+.0f}"][reference] for r in rows for t in TURNS_DEG]
    got = np.abs([e for e in errs if e is not None])
    return {
        "clips": len(errs),
        "tracked_share": len(got) / max(len(errs), 1),
        "err_median_deg": float(np.median(got)) if got.size else None,
        "err_p95_deg": float(np.percentile(got, 95)) if got.size else None,
        "within_0.5_share": float(np.mean(got <= 0.5)) if got.size else None,
    }


def group_table(groups: dict[str, list[dict]]) -> tuple[dict, list[str], list[list]]:
    """The figures of each group of rows (`summary` per reference, inspect's and the outline ROIs' shares), and the
    report's header and table."""
    figures = {g: {ref: summary(rs, ref) for ref in ("image", "container")} for g, rs in groups.items()}
    for g, rs in groups.items():
        figures[g]["inspect_share"] = float(np.mean([r["inspect_tracks"] for r in rs]))
        for name in OUTLINE_ROIS:
            figures[g][f"{name}_share"] = float(np.mean([r[name] is not None for r in rs]))
    table = [
        [
            g,
            len(groups[g]),
            fmt(f["inspect_share"], True),
            *(fmt(f[f"{name}_share"], True) for name in OUTLINE_ROIS),
            *(fmt(f[ref][k], k.endswith("share")) for ref in ("image", "container") for k in KEYS),
        ]
        for g, f in figures.items()
    ]
    header = [
        "scenes",
        "glasses",
        "unturned glasses that inspect's suggested command tracks",
        "unturned, tracked with an ROI on the glass's outline",
        "... with one 3 % inside it",
    ] + [f"{ref}: {label}" for ref in ("image", "container") for label in LABELS]
    return figures, header, table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--holdout",
        action="store_true",
        help="the 20 held-out scenes (other seeds; tracked once before anything was tuned on them)",
    )
    ap.add_argument(
        "--large",
        action="store_true",
        help="with --holdout: its scenes rendered at 1920x1440, twice the size (a phone's picture is that large)",
    )
    args = ap.parse_args()
    if args.large and not args.holdout:
        ap.error("--large renders the held-out scenes larger: give it with --holdout.")
    holdout = args.holdout
    which = "holdout_1920" if args.large else "holdout" if holdout else "tuned"
    scenes = DRAWS[which].scenes
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        rows = [case_row(i, Path(tmp), which) for i in range(scenes)]
    groups = {
        "all": rows,
        f"camera below {HIGH_DEG:g} deg": [r for r in rows if r["elevation_deg"] < HIGH_DEG],
        f"camera {HIGH_DEG:g}-20 deg above": [r for r in rows if r["elevation_deg"] >= HIGH_DEG],
        "cola": [r for r in rows if "cola" in r["scene"]],
        "orange": [r for r in rows if "orange" in r["scene"]],
        "red": [r for r in rows if "red" in r["scene"]],
    }
    figures, header, table = group_table(groups)
    notes = (
        f"{scenes} glasses on a table drawn like issue 37's unseen real photos (see the script's docstring), each "
        f"turned by 0, +5 and -7 deg ({FRAMES} frames each) and tracked with no option; a refusal or fewer than 80 % "
        "of frames valid is not tracked. Error: the median tracked angle less the scene's truth (plus the turn, "
        "against the image); 'container': the angle relative to the container. Each unturned clip is also given to `sloshid inspect`, "
        "and the command it suggests is run (tracked: 80 % of frames valid), and is tracked against the image with an "
        "ROI drawn on the glass's outline (the scene's box) and with one 3 % of its width inside it. "
        + (
            "The held-out scenes rendered at 1920x1440 (twice the size) on 2026-12-05, after their 960 px pictures, "
            "scaled up, had shown refusals at 1920 px (a cola's core, an orange juice's front edge). Their first run, "
            "before the tracker measured a large picture reduced when only that measures its surface, tracked 59 of "
            "the 60 clips (image median / p95 0.040 / 0.151 deg, container 0.050 / 0.206); nothing was tuned on them. "
            if args.large
            else "Held out: seeds 900 on, drawn and rendered after the tracker's changes of 2026-12-05; its first run "
            "(8-frame clips, 90 % tracked) was made before anything was tuned on it, and its refusals led to the next "
            "fixes (the edge below a back rim, the search below a back edge), so it is seen now. "
            if holdout
            else "Made after the tracker's changes of 2026-12-05 (the surface ellipse's centre, the walls' lowest "
            "rows, the ellipse's ends on the walls, a dark liquid read further out, an ROI that cuts the walls "
            "widened) were found on these scenes: tuned on. "
        )
        + f"Total time {(time.perf_counter() - t0) / 60:.1f} min."
    )
    write_results(
        "track_table_glasses" + {"tuned": "", "holdout": "_holdout", "holdout_1920": "_holdout_1920"}[which],
        {"figures": figures, "cases": rows},
        "Glasses on a table (like the outside check's photos), turned, tracked with no option"
        + {"tuned": "", "holdout": ": held out", "holdout_1920": ": held out, 1920x1440"}[which],
        header,
        table,
        notes,
    )


if __name__ == "__main__":
    main()
