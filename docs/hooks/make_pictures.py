"""Redraw the getting-started page's pictures (`docs/img/`) from the bundled sample: run from the repository root,
`python docs/hooks/make_pictures.py`. They are committed, not made at each build: a build should not track a video."""

from __future__ import annotations

import matplotlib

import sloshid

matplotlib.use("Agg")
OUT = "docs/img"

sloshid.inspect("data/sample_tap.mp4", picture=f"{OUT}/inspect.png")
tracked = sloshid.track("data/sample_tap.mp4", float_color="red")
ident = sloshid.identify(tracked, mass_kg=0.5)
plan = sloshid.plan("data/scenarios/demo_move.toml", ident)
for name, result in (("track", tracked), ("identify", ident), ("plan", plan)):
    figure = result.plot()
    figure.set_size_inches(8, 4.5)
    figure.savefig(f"{OUT}/{name}.png", dpi=80, bbox_inches="tight")
