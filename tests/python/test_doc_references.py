"""Every citation of the project's own documents resolves: a path like ``docs/math/laws.md#law-gated``
in code, docstrings, notebooks, the README or the docs names a file that exists and, after ``#``, a
target defined in it (a MyST label ``(name)=`` or a heading's slug). Markdown links to local files
resolve too, and nothing cites a file outside the repository."""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TEXT_SUFFIXES = {".py", ".cpp", ".hpp", ".h", ".c", ".md", ".ipynb", ".json", ".txt", ".cmake", ".in", ".toml"}
# A citation of a project document: docs/...md or README.md, with an optional #anchor.
CITATION = re.compile(r"(?<![\w/.-])((?:docs/[\w/.-]+|README)\.md)(?:#([\w-]+))?")
# The developers' private notes (spelled in pieces so this file does not match itself).
OUTSIDE = re.compile("|".join(["LAWS" + r"\.md", r"\.\./" + "shared", "shared/" + "design", "shared/" + "papers"]))
MD_LINK = re.compile(r"\]\(([^)#\s]+)(?:#([\w-]+))?\)")


def tracked_text_files() -> list[Path]:
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.split()
    this = Path(__file__).resolve()
    return [ROOT / f for f in out
            if Path(f).suffix in TEXT_SUFFIXES and (ROOT / f).is_file() and (ROOT / f).resolve() != this]


def _slug(heading: str) -> str:
    text = re.sub(r"[^\w\s-]", "", heading.strip().lower())
    return re.sub(r"\s+", "-", text)


def anchors(path: Path) -> set[str]:
    text = path.read_text(encoding="utf-8")
    labels = set(re.findall(r"^\((?P<name>[\w-]+)\)=\s*$", text, flags=re.M))
    headings = {_slug(h) for h in re.findall(r"^#+\s+(.*)$", text, flags=re.M)}
    return labels | headings


def citations() -> list[tuple[str, int, str, str | None]]:
    found = []
    for path in tracked_text_files():
        rel = path.relative_to(ROOT).as_posix()
        for lineno, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            for m in CITATION.finditer(line):
                found.append((f"{rel}:{lineno}", m.group(1), m.group(1), m.group(2)))
            if path.suffix == ".md":
                for m in MD_LINK.finditer(line):
                    target = m.group(1)
                    if "://" in target or target.startswith("mailto:"):
                        continue
                    resolved = (path.parent / target).resolve().relative_to(ROOT).as_posix() \
                        if (path.parent / target).resolve().is_relative_to(ROOT) else "../" + target
                    found.append((f"{rel}:{lineno}", target, resolved, m.group(2)))
    return found


CITATIONS = citations()


def test_there_are_citations_to_check():
    # The check must see the citations it exists for (a broken pattern would pass vacuously).
    assert sum(1 for _, shown, _, _ in CITATIONS if shown.startswith("docs/math/")) >= 20


@pytest.mark.parametrize("where,shown,path,anchor", CITATIONS, ids=[f"{w} {s}" for w, s, _, _ in CITATIONS])
def test_citation_resolves(where, shown, path, anchor):
    target = ROOT / path
    assert target.is_file(), f"{where}: cites {shown}, which is not a file of the repository"
    if anchor and target.suffix == ".md":
        assert anchor in anchors(target), f"{where}: {shown}#{anchor}: no such label or heading in {path}"


def test_nothing_cites_notes_outside_the_repository():
    bad = []
    for path in tracked_text_files():
        for lineno, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if OUTSIDE.search(line):
                bad.append(f"{path.relative_to(ROOT)}:{lineno}")
    assert not bad, "cites files that are not in the repository: " + ", ".join(bad)


def test_the_check_fails_on_a_dangling_citation(tmp_path):
    # The same resolution rules reject a missing file and a missing anchor.
    page = ROOT / "docs" / "math" / "laws.md"
    assert "law-gated" in anchors(page)
    assert "law-no-such-law" not in anchors(page)
    assert not (ROOT / "docs" / "math" / "no_such_page.md").exists()
    m = CITATION.search("see docs/math/laws.md#law-no-such-law")
    assert m and m.group(1) == "docs/math/laws.md" and m.group(2) == "law-no-such-law"
