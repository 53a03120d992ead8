"""`glintlab report` (the job behind `make run`): every section runs, the page shows every figure.

One quick report is built per test session (about 40 s) and checked as data (report.json, CSVs) and as
a user sees it: rendered by Debian's headless chromium, each figure must be decoded by the browser and
visible (not blank) in a screenshot of the whole page.
"""
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

from glintlab.api.registry import Registry
from glintlab.cli.main import main
from glintlab.report import sections
from glintlab.report.config import check_type, load_config, section_params
from glintlab.report.sections import SECTIONS

CHROMIUM = shutil.which("chromium")
BROWSER_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--allow-file-access-from-files"]


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    assert main(["report", "--quick", "--quiet", "--out", str(out)]) == 0
    return out, json.loads((out / "report.json").read_text())


def test_every_configured_section_ran_and_wrote_its_figures(quick_report):
    out, summary = quick_report
    doc, _ = load_config(None)
    assert summary["ran"] == [e["name"] for e in doc["sections"]]
    for name, sec in summary["sections"].items():
        assert f"--only {name}" in sec["command"] and "--quick" in sec["command"]
        assert sec["params"] == section_params(next(e for e in doc["sections"] if e["name"] == name), True)
    expected = {"sampler_vs_exact.png", "db23_figure9.png", "db23_figure4.png", "lod_strip.png",
                "roulette_vs_linear.png", "wwh18_threshold.png", "db23_figure13.png", "trade_pareto.png",
                "error_maps_tv.png", "extremes.png", "aniso_maps.png"}
    assert expected <= set(summary["figures"])
    for fig in summary["figures"]:
        assert (out / fig).stat().st_size > 10_000, fig  # a real plot, not an empty canvas
    for table in ("exact_laws", "sampler_checks", "speed_accuracy", "wwh18_threshold", "db23_figure13_summary",
                  "roulette_vs_linear", "extremes_summary", "bounds_check", "shaders_as_they_run"):
        assert summary["tables"][table] and (out / f"{table}.csv").stat().st_size > 0, table
    trade = {row["law"]: row for row in summary["tables"]["speed_accuracy"]}
    assert trade["binomial"]["tv_max"] < 1e-12 and trade["head_cf"]["tv_max"] < 0.01
    assert all(row["ok"] for row in summary["tables"]["bounds_check"])
    assert summary["failures"] == []


def test_figures_carry_their_findings(quick_report):
    _, summary = quick_report
    t = summary["tables"]
    mid = {r["blend"]: r for r in t["roulette_vs_linear"] if abs(r["w"] - 0.5) < 1e-9}
    # Linear blending: about twice the lit pixels at half the intensity; distributed: the truth.
    assert mid["linear (zk16_linear)"]["lit_share_vs_truth"] > 1.6
    assert mid["linear (zk16_linear)"]["lit_intensity_vs_truth"] < 0.65
    assert abs(mid["distributed"]["lit_share_vs_truth"] - 1) < 0.1
    # Convergence: slope -1/2 of the spread of D_P / D(h) for both NDFs.
    assert all(abs(r["slope"] + 0.5) < 0.03 for r in t["db23_figure13_summary"])
    # Glinty NDFs: KPT25's Algorithm 1 equals its reference on average while the lobe is inside the disk,
    # and linear blending loses the glints' spread that the roulette keeps.
    kpt = [r for r in t["glinty_ndf"] if r["method"].startswith("kpt25") and r["rho"] <= 0.8 and r["alpha_star"] <= 0.02]
    assert kpt and all(abs(r["bias_vs_ref_exact"]) < 1e-2 for r in kpt)
    mid = {r["blend"]: r for r in t["glinty_ndf_blend"] if r["level_frac"] == 0.5}
    assert mid["linear"]["rel_std_vs_one_level"] < mid["roulette eps=0.1"]["rel_std_vs_one_level"]
    # The threshold trade: the worst error falls as T grows.
    worst = [r["rel_intensity_err_max"] for r in t["wwh18_threshold"] if not r["explicit"]]
    assert all(a >= b for a, b in zip(worst, worst[1:]))


def test_only_reruns_one_section_and_keeps_the_page_whole(quick_report, tmp_path):
    out, summary = quick_report
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    assert main(["report", "--quick", "--quiet", "--out", str(copy), "--only", "wwh18_threshold"]) == 0
    again = json.loads((copy / "report.json").read_text())
    assert again["ran"] == ["wwh18_threshold"] and set(again["figures"]) == set(summary["figures"])
    assert again["tables"]["wwh18_threshold"][0]["T"] == summary["tables"]["wwh18_threshold"][0]["T"]


def _render(page, tmp_path):
    """(DOM after load, screenshot as an array, scale): chromium renders the page as a user would."""
    assert CHROMIUM, "chromium is missing: make build installs it (scripts/install-deps.sh)"
    # The same window width in both runs: the layout (and so every figure's rectangle) depends on it.
    dom = subprocess.run([CHROMIUM, *BROWSER_FLAGS, "--window-size=1200,2000", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    height = int(re.search(r'data-height="(\d+)"', dom).group(1))
    scale = min(1.0, 16000 / height)  # chromium's screenshot limit
    shot = tmp_path / "page.png"
    subprocess.run([CHROMIUM, *BROWSER_FLAGS, f"--force-device-scale-factor={scale}", f"--screenshot={shot}",
                    f"--window-size=1200,{height}", page.as_uri()], capture_output=True, timeout=120, check=True)
    from matplotlib.image import imread
    return dom, imread(shot), scale


def _figures_on_screen(dom, image, scale):
    """Per <img src>: whether the browser decoded it and its screenshot region is not blank."""
    found = {}
    for tag in re.findall(r"<img [^>]*>", dom):
        src = re.search(r'src="([^"]+)"', tag).group(1)
        rect = re.search(r'data-rect="([\d,.-]+)"', tag)
        if not rect:
            found[src] = False
            continue
        x, y, w, h = (float(v) * scale for v in rect.group(1).split(","))
        crop = image[int(y):int(y + h), int(x):int(x + w), :3]
        found[src] = crop.size > 0 and w > 100 and float(crop.std()) > 0.02 and float((crop < 0.9).mean()) > 0.01
    return found


def test_headless_browser_shows_every_figure(quick_report, tmp_path):
    out, summary = quick_report
    dom, image, scale = _render(out / "index.html", tmp_path)
    shown = _figures_on_screen(dom, image, scale)
    assert set(shown) == set(summary["figures"])
    assert all(shown.values()), [k for k, v in shown.items() if not v]
    assert f'data-images-loaded="{len(summary["figures"])}"' in dom
    for sec in summary["sections"].values():
        assert sec["title"].split(":")[0].replace("&", "&amp;") in dom


def test_headless_check_fails_on_a_missing_or_blank_figure(quick_report, tmp_path):
    out, summary = quick_report
    broken = tmp_path / "broken"
    shutil.copytree(out, broken)
    missing, blank = summary["figures"][0], summary["figures"][1]
    (broken / missing).unlink()
    from matplotlib.image import imread, imsave
    imsave(broken / blank, np.ones_like(imread(out / blank)))
    dom, image, scale = _render(broken / "index.html", tmp_path)
    shown = _figures_on_screen(dom, image, scale)
    assert shown[missing] is False and shown[blank] is False
    assert sum(shown.values()) == len(summary["figures"]) - 2


def test_quick_viewer_is_small_opens_every_scene_and_sits_in_the_page(quick_report):
    # The image viewer of the quick report: the page and its media (scene_images.*) under 15 MB; every
    # scene opens in the browser (the keys of the page), nothing is requested outside the file, no error.
    from chromium_cdp import Browser
    from glintlab.report.viewer import manifest_of
    out, summary = quick_report
    page = out / "scene_images.html"
    media = sum(p.stat().st_size for p in out.glob("scene_images*") if p.is_file())
    assert media < 15e6, media
    assert "<iframe id='viewer' src='scene_images.html'" in (out / "index.html").read_text()
    scenes = [d["name"] for d in manifest_of(page)["scenes"]]
    b = Browser(1400, 1000)
    try:
        b.open(page.as_uri())
        for i, name in enumerate(scenes):
            if i:
                b.key("ArrowDown", "ArrowDown")
            b.wait("(() => { const s = document.getElementById('gv-canvas').dataset.state;"
                   f" return s && JSON.parse(s).scene === {json.dumps(name)}; }})()")
        assert all(u == page.as_uri() or u.startswith(("blob:", "data:")) for u in b.requests), b.requests
        assert b.errors == []
    finally:
        b.close()


def test_bad_arguments_and_configs_exit_2(tmp_path, capsys):
    assert main(["report", "--seed", "-1", "--quiet", "--out", str(tmp_path / "x")]) == 2
    assert "seed = -1" in capsys.readouterr().err
    assert main(["report", "--only", "nope", "--quiet", "--out", str(tmp_path / "x")]) == 2
    assert "only = 'nope'" in capsys.readouterr().err
    assert main(["no-such-command"]) == 2
    cases = [
        ("{", "at /: expected valid JSON"),
        ('{"kind": "report"}', 'at /sections: expected the required field "sections", got nothing'),
        ('{"kind": "report", "sections": [{"name": "nope"}]}', "at /sections/0/name: expected one of"),
        ('{"kind": "report", "sections": [{"name": "exact_laws", "params": {"samples": 0}}]}',
         "at /sections/0/params/samples: expected an integer >= 1"),
        ('{"kind": "report", "sections": [{"name": "exact_laws", "quick": {"sample": 5}}]}',
         "at /sections/0/quick/sample: expected a parameter of exact_laws"),
        ('{"kind": "report", "sections": [{"name": "wwh18_threshold", "params": {"thresholds": [1, -2]}}]}',
         "at /sections/0/params/thresholds: expected a non-empty list of finite numbers > 0"),
        ('{"kind": "report", "sections": [{"name": "lighting", "params": {"scene_methods": ["zk16", 3]}}]}',
         "at /sections/0/params/scene_methods: expected a non-empty list of non-empty strings"),
        ('{"kind": "report", "sections": [{"name": "lighting", "quick": {"sphere_envmap_scale": -1}}]}',
         "at /sections/0/quick/sphere_envmap_scale: expected null or a finite number > 0"),
        ('{"kind": "report", "seed": -3, "sections": [{"name": "exact_laws"}]}', "at /seed:"),
    ]
    for text, message in cases:
        path = tmp_path / "config.json"
        path.write_text(text)
        assert main(["report", "--config", str(path), "--quiet", "--out", str(tmp_path / "y")]) == 2, text
        err = capsys.readouterr().err
        assert str(path) in err and message in err, (text, err)


def test_readme_says_what_each_figure_means():
    # The README's table of sections carries each section's one-sentence meaning verbatim (kept in sync).
    readme = (ROOT / "README.md").read_text()
    doc, _ = load_config(None)
    for entry in doc["sections"]:
        sec = SECTIONS.get(entry["name"])
        assert f"| `{sec.name}` | {sec.title} | {sec.meaning} |" in readme, sec.name
    assert (ROOT / "docs" / "figures" / "report_thumbnail.png").stat().st_size > 50_000


def test_sections_are_the_discovered_studies():
    # Every study module of glintlab.studies is a section; the default configuration runs each once and
    # only names them (parameters and quick sizes live in the study modules).
    # The count is derived, not written by hand: each study module (a file of glintlab/studies that
    # assigns NAME, read as text rather than imported) is one section, and the configuration names each once.
    doc, _ = load_config(None)
    studies = Path(sections.studies.__file__).parent
    study_files = [p.stem for p in studies.rglob("*.py") if re.search(r"^NAME = ", p.read_text(), re.M)]
    assert len(SECTIONS) == len(study_files) == len(doc["sections"]), sorted(study_files)
    assert sorted(e["name"] for e in doc["sections"]) == sorted(SECTIONS.names())
    assert all(set(e) == {"name"} for e in doc["sections"])
    for name, sec in SECTIONS.items():
        assert sec.name == name and sec.title and sec.meaning and sec.defaults, name
        for key, value in sec.quick.items():
            check_type(f"{name}.QUICK.{key}", value, sec.defaults[key])
        assert section_params({"name": name}, False) == sec.defaults
        assert section_params({"name": name}, True) == {**sec.defaults, **sec.quick}
    # An entry's params beat the study's QUICK; its quick beats both.
    assert section_params({"name": "exact_laws", "params": {"samples": 7}}, True)["samples"] == 7
    both = {"name": "exact_laws", "params": {"samples": 7}, "quick": {"samples": 3}}
    assert section_params(both, True)["samples"] == 3
    assert section_params({"name": "exact_laws", "quick": {"samples": 3}}, False)["samples"] == 1_000_000
    assert sections.discover().names() == SECTIONS.names()


def test_registry_refuses_duplicates_and_names_the_known():
    r = Registry("report section")
    r.register("a", 1)
    r.register("b", 2)
    with pytest.raises(ValueError, match="'a' is already registered"):
        r.register("a", 3)
    with pytest.raises(ValueError, match=r"unknown report section 'x'; known: a, b"):
        r.get("x")
    assert r.names() == ["a", "b"] and r.items() == [("a", 1), ("b", 2)] and "a" in r and len(r) == 2
