"""The HTML pages glintlab writes: the report's ``index.html`` and the extremes suite's ``extremes.html``
(``glintlab extremes``, and the report's extremes section). Both go through :func:`page`, the one page
writer; the rest builds their bodies."""
from __future__ import annotations

import base64
import html
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from ..studies.base import Tables
from ..studies.extremes import failure_matrix_figure
from ..validation.extremes import CHECKS, failed_checks
from . import viewer

escape = html.escape


def page(path, title: str, css: str, body: str, script: str = "") -> Path:
    """Writes a self-contained HTML page (UTF-8) to ``path`` and returns the path."""
    path = Path(path)
    path.write_text(f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{escape(title)}</title>"
                    f"<style>{css}</style></head><body>\n{body}\n{script}</body></html>\n", encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------------------
# The report page (index.html).

REPORT_CSS = ("body{font-family:sans-serif;max-width:1150px;margin:auto;padding:0 12px;color:#222}"
              "img{max-width:100%;height:auto}figure{margin:8px 0}.meaning{font-size:15px}.how{font-size:12px;color:#555}"
              ".stats{font-size:13px}.fail{color:#b2182b}section{border-top:1px solid #ccc;margin-top:18px}"
              "table{border-collapse:collapse;font-size:11px}td,th{padding:2px 6px;border-bottom:1px solid #ddd}"
              "code{background:#f4f4f4;padding:1px 3px}")
# Marks every image that decoded with its page rectangle, and the page height, so a headless browser
# test (tests/python/test_report.py) can find each figure in a screenshot and check it is not blank.
REPORT_SCRIPT = ("<script>window.addEventListener('load',function(){var n=0;for(var i of document.images)"
                 "{if(i.complete&&i.naturalWidth>0){n++;var r=i.getBoundingClientRect();i.setAttribute('data-rect',"
                 "[r.left+scrollX,r.top+scrollY,r.width,r.height].map(Math.round).join(','));}}"
                 "document.body.setAttribute('data-images-loaded',String(n));document.body.setAttribute("
                 "'data-height',String(document.documentElement.scrollHeight));});</script>")


def fmt(v) -> str:
    """A headline number as the page and the terminal show it."""
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def png_size(path: Path):
    """(width, height) from a PNG's IHDR chunk, so the page reserves each figure's box before it loads."""
    try:
        head = Path(path).read_bytes()[:24]
    except OSError:
        return None
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


# The image viewer is its own page (large, with its own script and a Content-Security-Policy); the report
# shows it in a frame of fixed height (the viewer sizes its canvases to the frame's window, so a frame that
# followed the viewer's height would chase it).
VIEWER_FRAME = ("<p><a href='{page}'>Open the image viewer on its own page</a> (every render at full resolution, "
                "exposure, tone curve, differences, zoom, the flicker video).</p>"
                "<iframe id='viewer' src='{page}' title='glint image viewer' style='width:100%;height:1500px;"
                "border:1px solid #ccc'></iframe>")


def _viewer_frame(out: Path, name: str) -> list:
    page = SECTION_VIEWERS.get(name)
    return [VIEWER_FRAME.format(page=page)] if page and (out / page).exists() else []


def write_report_page(out, summary: dict, records: list) -> Path:
    """``out/index.html`` from the report's summary (report.json) and its section records, in page order."""
    out, e = Path(out), escape
    toc = "".join(f'<li><a href="#{r["name"]}">{e(r["title"])}</a></li>' for r in records)
    parts = [f"<h1>glintlab {e(summary['glintlab_version'])}: what is known about glint counting laws</h1>",
             f"<p>Regenerate the whole page: <code>{e(summary['command'])}</code> (configuration "
             f"<code>{e(summary['config'])}</code>, seed {summary['seed']}"
             f"{', quick sizes' if summary['quick'] else ''}). Each section says how to regenerate it alone. "
             f"Tables are the CSV files beside this page.</p>"]
    if summary["failures"]:
        parts.append('<p class="fail"><b>Failed checks:</b> ' + "; ".join(e(f) for f in summary["failures"]) + "</p>")
    # The page opens on the first section's pictures (the configuration's first entry: the glint images
    # of the scenes in the default report), then the table of contents and the other sections.
    for i, r in enumerate(records):
        if i == 1 or (i == 0 and len(records) == 1):
            parts.append(f"<ol class='toc'>{toc}</ol>")
        parts.append(f'<section id="{r["name"]}"><h2>{e(r["title"])}</h2><p class="meaning">{e(r["meaning"])}</p>')
        figures = []
        for fig in r["figures"]:
            size = png_size(out / fig)
            dims = f' width="{size[0]}" height="{size[1]}"' if size else ""
            figures.append(f'<figure><img src="{e(fig)}" alt="{e(Path(fig).stem)}"{dims}></figure>')
        if i == 0:  # the opening picture comes before the numbers
            parts += _viewer_frame(out, r["name"]) + figures
        if r["stats"]:
            parts.append("<ul class='stats'>" + "".join(f"<li>{e(k)}: <b>{e(fmt(v))}</b></li>"
                                                        for k, v in r["stats"].items()) + "</ul>")
        for f in r["failures"]:
            parts.append(f'<p class="fail">FAILED: {e(f)}</p>')
        if i > 0:
            parts += figures
        params = ", ".join(f"{k} = {json.dumps(v)}" for k, v in r["params"].items())
        nb = f"; notebook <code>notebooks/{e(r['notebook'])}</code>" if r["notebook"] else ""
        parts.append(f"<p class='how'>Parameters: {e(params)}; seed {r['seed']}; {r['seconds']} s"
                     + (f" ({r['cpu_seconds']} s CPU)" if r.get("cpu_seconds") is not None else "") + ". "
                     f"Regenerate alone: <code>{e(r['command'])}</code>{nb}.</p>")
        for name, rows in r["tables"].items():
            df = pd.DataFrame(rows)
            parts.append(f"<details><summary>table {e(name)} ({len(df)} rows, <a href='{e(name)}.csv'>{e(name)}.csv</a>)"
                         f"</summary>{df.head(200).to_html(index=False, float_format=lambda v: f'{v:.6g}', border=0)}"
                         "</details>")
        parts.append("</section>")
    return page(out / "index.html", "glintlab report", REPORT_CSS, "\n".join(parts), REPORT_SCRIPT)


# --------------------------------------------------------------------------------------------------
# The extremes page (extremes.html): self-contained, no script, no link outside it.

EXTREMES_CSS = """
body { font-family: sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; font-size: 12px; margin-bottom: 1.5em; }
th, td { border: 1px solid #bbb; padding: 2px 6px; text-align: right; vertical-align: top; }
th { background: #eee; }
td.text { text-align: left; max-width: 40em; }
td.fail { background: #f4b6b6; color: #7a0000; font-weight: bold; }
td.pass { background: #d9f2d9; }
td.na { background: #f2f2f2; color: #888; }
"""


def _cell(value, cls=""):
    if isinstance(value, (float, np.floating)):
        text = "" if np.isnan(value) else f"{value:.10g}"
    else:
        text = "" if value is None or (value is pd.NA) else str(value)
    attr = f' class="{cls}"' if cls else ""
    return f"<td{attr}>{escape(text)}</td>"


def table(df: pd.DataFrame, fail_cells: pd.DataFrame | None = None, text_cols=()) -> str:
    """An HTML table of ``df``; cells marked True in ``fail_cells`` (same shape) get class "fail", columns
    in ``text_cols`` are left-aligned."""
    head = "".join(f"<th>{escape(str(c))}</th>" for c in df.columns)
    body = []
    for i, (_, r) in enumerate(df.iterrows()):
        cells = []
        for c in df.columns:
            cls = "text" if c in text_cols else ""
            if fail_cells is not None and fail_cells.iloc[i].get(c, False):
                cls = (cls + " fail").strip()
            cells.append(_cell(r[c], cls))
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _grid_value(x):
    return f"{x:.12g}" if isinstance(x, (float, np.floating)) else str(x)


def write_extremes_page(out, table_: pd.DataFrame, invalid: pd.DataFrame, summary: pd.DataFrame,
                        figure: Path) -> Path:
    """``out/extremes.html``: the figure (inlined), the summary with failing cells in red, every failing
    row and every invalid-input case that is not refused by name."""
    out = Path(out)
    png = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
    fails = failed_checks(table_)
    sum_fail = pd.DataFrame({c: (summary[c] > 0) if c in CHECKS + ("failures",) else False
                             for c in summary.columns}, index=summary.index).reset_index(drop=True)
    failing = table_[~table_.ok]
    f = fails.loc[failing.index]
    row_fail = pd.DataFrame({c: False for c in failing.columns}, index=failing.index)
    for c in ("nonfinite", "below_zero", "above_n", "error", "pmf_mass"):
        row_fail[c] = f[c]
    row_fail["pmf_support_ok"] = f["pmf_support"]
    row_fail["ok"] = True
    row_fail = row_fail.reset_index(drop=True)
    bad_invalid = invalid[~invalid.ok.astype(bool)] if len(invalid) else invalid
    seconds = table_.attrs.get("seconds")
    meta = (f"{len(table_)} rows over {table_.law.nunique()} laws / blend footprints; "
            f"{int((~table_.ok).sum())} failing rows; samples = {table_.attrs.get('samples', '?')}, "
            f"seed = {table_.attrs.get('seed', '?')}"
            + (f"; computed in {seconds:.1f} s" if seconds is not None else ""))
    parts = [
        "<h1>Numerical extremes (docs/math/extremes.md)</h1>",
        f"<p>{escape(meta)}.</p>",
        "<p>Grid n &isin; {" + ", ".join(_grid_value(x) for x in sorted(table_.n.unique())) + "}, p &isin; {"
        + ", ".join(_grid_value(x) for x in sorted(table_.p.unique())) + "}; uniform sets: ordinary, corners "
        "(coordinates exactly 0, 1/2, 1), half (ordinary rounded to float16). Each evaluation must give a "
        "finite K in [0, &lceil;n&rceil;] without raising; the exact pmf must sum to 1 (1e-9) on a support in "
        "[0, &lceil;n&rceil;]. Mean bias (mean_z) is reported, not checked.</p>",
        f"<p><img alt='law x check failure counts' style='max-width: 100%' src='data:image/png;base64,{png}'></p>",
        "<h2>Summary</h2>",
        table(summary, sum_fail, text_cols=("law", "kind", "precision", "failed_checks", "where_failed")),
        f"<h2>Failing rows ({len(failing)})</h2>",
        table(failing, row_fail, text_cols=("law", "kind", "precision", "uniforms", "bound", "pmf_note", "error")),
        f"<h2>Invalid inputs: {int(invalid.ok.astype(bool).sum()) if len(invalid) else 0} of {len(invalid)} "
        "cases raise a ValueError naming the parameter and the value</h2>",
    ]
    if len(bad_invalid):
        parts.append(f"<p>Cases that do not ({len(bad_invalid)}):</p>")
        marks = pd.DataFrame({c: (c == "ok") for c in bad_invalid.columns}, index=range(len(bad_invalid)))
        parts.append(table(bad_invalid, marks, text_cols=("law", "method", "precision", "parameter",
                                                          "outcome", "message")))
    else:
        parts.append("<p>All cases pass.</p>")
    return page(out / "extremes.html", "glintlab: numerical extremes", EXTREMES_CSS, "\n".join(parts))


INVALID_COLUMNS = ["law", "method", "precision", "parameter", "value", "outcome", "message", "ok"]


def write_extremes_report(out_dir, table: pd.DataFrame, invalid: pd.DataFrame | None, summary: pd.DataFrame,
                          figure=None) -> Path:
    """Writes extremes.csv, extremes_invalid.csv, extremes_summary.csv, extremes.png (law x check
    matrix of failure counts, float64 and float32 side by side; a copy of ``figure`` when given) and a
    self-contained extremes.html (summary with failing cells in red, then every failing row and every
    failing invalid-input case). Returns the path of extremes.html."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    invalid = invalid if invalid is not None else pd.DataFrame(columns=INVALID_COLUMNS)
    table.to_csv(out / "extremes.csv", index=False)
    invalid.to_csv(out / "extremes_invalid.csv", index=False)
    summary.to_csv(out / "extremes_summary.csv", index=False)
    if figure is None:
        failure_matrix_figure(summary, out / "extremes.png")
    else:
        shutil.copy(figure, out / "extremes.png")
    return write_extremes_page(out, table, invalid, summary, out / "extremes.png")


# --------------------------------------------------------------------------------------------------
# Pages of their own that report sections have besides their part of index.html.

def _extremes_section_page(tables: Tables, out: Path) -> Path:
    return write_extremes_report(out / "extremes", tables["table"], tables["invalid"], tables["extremes_summary"],
                                 figure=out / "extremes.png")


def scene_images_viewer(tables: Tables, out) -> Path:
    """``out/scene_images.html``, the image viewer of the glint images (report section ``scene_images`` and
    ``glintlab images``; :mod:`glintlab.report.viewer`)."""
    intro = ("<p>Every method's render of frame 1 at full resolution, stored as float16 radiance: pick the "
             "exposure (stops) and the tone curve, compare with the method's own truth and the facet truth (hold "
             "<kbd>space</kbd> or <kbd>f</kbd>), zoom to pixels, and watch the flicker along the camera path "
             "(docs/guide/scenes.md, docs/math/glint_images.md). This page loads nothing from outside itself.</p>")
    return viewer.write_viewer(out, tables["views"], "glintlab: glint images per method", intro,
                               tables["scene_images_flicker"])


SECTION_PAGES = {"extremes": _extremes_section_page, "scene_images": scene_images_viewer}
SECTION_VIEWERS = {"scene_images": viewer.PAGE}


def write_section_pages(name: str, tables: Tables, out) -> list:
    """The pages of section ``name`` besides index.html (the extremes suite's), after its figures."""
    return [SECTION_PAGES[name](tables, Path(out))] if name in SECTION_PAGES else []
