"""Benchmark: the held-out glasses seen through a phone camera's processing, turned and tracked with no option.

Issue 37's unseen real photos went through a camera: a lens that blurs a little and splits colours at the picture's
edges (lateral chromatic aberration), darker corners (vignetting), the phone's sharpening (a bright and a dark halo
beside every edge) and JPEG. The renders have none of these. This takes the 20 held-out glasses of
`track_table_glasses.py --holdout` (data/table_glasses_holdout/, rendered there when missing; never tuned on), passes
each picture through `sloshid.synthetic.stills.camera_look` with one artefact at a time and with all of them, and
tracks it as the outside check did (turned by 0, +5 and -7 deg, `still_clip`, 15 frames, `--target surface`, no
option), against the image and the container, beside the clean pictures in the same run. With --tuned: the 30 tuned
glasses instead. Writes reports/benchmarks/track_camera_look.{json,md} (--tuned: track_camera_look_tuned). Run from
the repository root: python3 benchmarks/track_camera_look.py (about 15 min on two cores once the glasses are rendered).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np
from bench_output import write_results
from track_table_glasses import DRAWS, KEYS, LABELS, case_row, summary
from track_turned import fmt

from sloshid.synthetic.stills import camera_look

LOOKS = {
    "clean": {},
    "defocus 1.2 px": {"defocus_px": 1.2},
    "chromatic aberration 0.2 %": {"chromatic": 0.002},
    "vignette 35 %": {"vignette": 0.35},
    "sharpened 1.2": {"sharpen": 1.2},
    "JPEG 75": {"jpeg_quality": 75},
    "all of them": {"defocus_px": 1.2, "chromatic": 0.002, "vignette": 0.35, "sharpen": 1.2, "jpeg_quality": 75},
}
"""Each artefact about as strong as a phone's at 960 px across (the chromatic aberration moves a corner's red and blue
1.2 px apart), alone and together."""
FRAMES = 15
"""Frames per clip: a third of track_table_glasses' 45 (seven looks of 60 clips each), the same for every look."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tuned", action="store_true", help="the 30 tuned glasses instead of the 20 held-out ones")
    args = ap.parse_args()
    which = "tuned" if args.tuned else "holdout"
    t0 = time.perf_counter()
    rows: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for look, kwargs in LOOKS.items():
            print(f"-- {look}")
            see = partial(camera_look, **kwargs) if kwargs else None
            rows[look] = [case_row(i, Path(tmp), which, see, FRAMES) for i in range(DRAWS[which].scenes)]
    figures = {look: {ref: summary(rs, ref) for ref in ("image", "container")} for look, rs in rows.items()}
    for look, rs in rows.items():
        figures[look]["inspect_share"] = float(np.mean([r["inspect_tracks"] for r in rs]))
    table = [
        [
            look,
            fmt(f["inspect_share"], True),
            *(fmt(f[ref][k], k.endswith("share")) for ref in ("image", "container") for k in KEYS),
        ]
        for look, f in figures.items()
    ]
    header = ["look", "unturned glasses that inspect's suggested command tracks"] + [
        f"{ref}: {label}" for ref in ("image", "container") for label in LABELS
    ]
    notes = (
        f"The {DRAWS[which].scenes} {'tuned' if args.tuned else 'held-out'} glasses of track_table_glasses "
        "(960x720), each picture passed through `camera_look` with the artefact named (defocus: Gaussian sigma; "
        "chromatic aberration: red magnified and blue shrunk by that share about the centre; vignette: the corners "
        "darkened by that share; sharpened: an unsharp mask of that strength, sigma 1.5 px; JPEG at that quality), "
        f"turned by 0, +5 and -7 deg ({FRAMES} frames each, sensor noise 3, H.264 CRF 20) and tracked with no option; "
        "a refusal or fewer than 80 % of frames valid is not tracked. Error: the median tracked angle less the scene's "
        "truth (plus the turn, against the image); 'container': relative to the container. Each unturned clip is also "
        "given to `sloshid inspect` and the command it suggests is run. "
        f"Total time {(time.perf_counter() - t0) / 60:.1f} min."
    )
    write_results(
        "track_camera_look" + ("_tuned" if args.tuned else ""),
        {"figures": figures, "cases": rows},
        "Held-out glasses seen through a camera's processing, turned, tracked with no option"
        if not args.tuned
        else "Tuned glasses seen through a camera's processing, turned, tracked with no option",
        header,
        table,
        notes,
    )


if __name__ == "__main__":
    main()
