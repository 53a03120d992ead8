"""A contact sheet of a report's figures: the README's picture."""
from __future__ import annotations

import json
import math
from pathlib import Path

from .sections import SECTIONS


def thumbnail(out, path, columns: int = 4, width_px: int = 1400) -> Path:
    """A contact sheet of a report's figures (the first figure of each section, titled), e.g. the
    README's picture: ``thumbnail("out/report", "docs/figures/report_thumbnail.png")``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.image import imread
    out = Path(out)
    summary = json.loads((out / "report.json").read_text())
    picks = [(SECTIONS.get(k).short,
              next(iter(json.loads((out / "sections" / f"{k}.json").read_text())["figures"]), None))
             for k in summary["sections"]]
    picks = [(title, fig) for title, fig in picks if fig]
    rows = math.ceil(len(picks) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(width_px / 100, width_px / 100 * 0.62 * rows / columns * 1.6),
                             squeeze=False)
    for ax, (title, name) in zip(axes.ravel(), picks):
        ax.imshow(imread(out / name))
        ax.set_title(title, fontsize=9)
    for ax in axes.ravel():
        ax.axis("off")
    fig.suptitle(f"glintlab report{' (quick)' if summary['quick'] else ''}: the first figure of each section",
                 fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
