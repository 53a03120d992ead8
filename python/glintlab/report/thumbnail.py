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


#: The report's figures that the guide pages show (docs/figures/report/NAME), by page.
DOC_FIGURES = {
    "scenes.md": ("scene_images.png", "scene_images_flicker.png", "scene_plane_25_regimes.png"),
    "laws.md": ("sampler_vs_exact.png", "db23_figure9.png"),
    "blending.md": ("roulette_vs_linear.png", "lod_strip.png"),
    "aniso.md": ("aniso_maps.png", "aniso_weight_bias.png"),
    "sweeps.md": ("trade_pareto.png", "extremes.png"),
    "shaders.md": ("shaders_row_by_row.png",),
}


def docs_figures(out, dest=None, width_px: int = 1000) -> list:
    """Copies the report's figures the guide pages show (:data:`DOC_FIGURES`) from a report in ``out``
    into ``dest`` (default ``docs/figures/report`` of the source tree), at most ``width_px`` wide and,
    for the plots, in 256 colours, so the repository stays small: after ``make run``,
    ``docs_figures("out/report")``. Returns the paths written."""
    from PIL import Image
    out = Path(out)
    dest = Path(dest) if dest else Path(__file__).resolve().parents[3] / "docs" / "figures" / "report"
    dest.mkdir(parents=True, exist_ok=True)
    written = []
    for name in sorted({n for names in DOC_FIGURES.values() for n in names}):
        img = Image.open(out / name)
        if img.width > width_px:
            img = img.resize((width_px, round(img.height * width_px / img.width)), Image.LANCZOS)
        # A plot's few colours survive a palette of 256; the renders' greys one of 64 (a preview: the report
        # and its viewer have every value).
        img = img.convert("RGB").quantize(64 if img.mode == "L" else 256, dither=Image.Dither.NONE)
        img.save(dest / name, optimize=True)
        written.append(dest / name)
    return written
