"""A self-contained HTML report (MNE-style): collect figures, tables and text, write one index.html."""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from sloshid import __version__
from sloshid.core.atomic import write_text
from sloshid.core.outputs import REPORT_MARK, Outputs

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1100px;margin:2em auto;
padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #36c;padding-bottom:.2em} h2{margin-top:2em;color:#235}
table{border-collapse:collapse;margin:.8em 0} th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#eef2f8} td:first-child,th:first-child{text-align:left}
figure{margin:1em 0} figcaption{color:#555;font-size:.92em} img{max-width:100%}
.verdict-good{color:#070;font-weight:bold} .verdict-uncertain{color:#b50;font-weight:bold}
.verdict-unreliable{color:#c00;font-weight:bold}
.meta{color:#666;font-size:.9em} code{background:#f4f4f4;padding:0 .2em}
"""


def figure_to_png_base64(fig: Any, dpi: int = 200) -> str:
    """Render a matplotlib figure to base64 PNG text and close it (about twice screen resolution, for sharp zoom)."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _fmt(value: Any) -> str:
    """Table cell text: floats with 4 significant digits, '-' for a missing or non-finite number, escaped."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, float):
        return html.escape(f"{value:.4g}")
    return html.escape(str(value))


@dataclass
class Report:
    """Collects report items in order; `save(dir)` writes them as one self-contained index.html."""

    title: str
    items: list[str] = field(default_factory=list)
    progress: bool = False
    """Count the figures on a tqdm bar (on a terminal) as they are drawn: a report of a dozen takes seconds."""
    _bar: Any = field(default=None, init=False, repr=False)

    def add_heading(self, text: str) -> None:
        """Start a new section."""
        self.items.append(f"<h2>{html.escape(text)}</h2>")

    def add_text(self, text: str, css_class: str | None = None) -> None:
        """A paragraph of plain text (escaped)."""
        cls = f' class="{css_class}"' if css_class else ""
        self.items.append(f"<p{cls}>{html.escape(text)}</p>")

    def add_html(self, fragment: str) -> None:
        """A raw HTML fragment (the caller escapes what it must)."""
        self.items.append(fragment)

    def add_figure(self, fig: Any, caption: str = "") -> None:
        """Embed a matplotlib figure as PNG, with a caption saying what to look at."""
        if self.progress and self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(desc=f"{self.title}: figures", unit="figure", disable=None, leave=False)
        data = figure_to_png_base64(fig)
        if self._bar is not None:
            self._bar.update()
        cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
        self.items.append(
            f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">{cap}</figure>'
        )

    def add_table(self, header: Sequence[str], rows: Sequence[Sequence[Any]], caption: str = "") -> None:
        """A table; floats are shown with 4 significant digits."""
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in row) + "</tr>" for row in rows)
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        self.items.append(f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")

    def add_links(self, links: dict[str, str]) -> None:
        """One line of links (text -> relative href), e.g. back to the pipeline index and to the stage's files."""
        if links:
            self.items.append(
                "<p>"
                + " · ".join(f'<a href="{html.escape(h)}">{html.escape(t)}</a>' for t, h in links.items())
                + "</p>"
            )

    def to_html(self) -> str:
        """The whole page as a string."""
        stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        return (
            f"<!DOCTYPE html><html><head><meta charset='utf-8'>{REPORT_MARK}"
            f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>"
            f"<p class='meta'>sloshid {html.escape(__version__)}, written {stamp}</p>"
            + "\n".join(self.items)
            + "</body></html>"
        )

    def save(self, directory: str | Path) -> Path:
        """Write `directory/index.html` atomically and return its path; never over an index.html sloshid did not
        write (`Outputs.report_dir`: the command line checks it before the work, every caller here)."""
        if self._bar is not None:
            self._bar.close()
        path = Outputs().report_dir(directory, "the report folder") / "index.html"
        write_text(path, self.to_html())
        return path
