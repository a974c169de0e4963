"""What git tracks stays small: source, tests, scenarios and the published
summaries, never generated meshes or per-flight sweep outputs."""

import os
import re

import pytest

from .conftest import ROOT, git_tracked

MAX_FILES = 1000
MAX_TOTAL_BYTES = 25 * 1024 * 1024
MAX_FILE_BYTES = 2 * 1024 * 1024


@pytest.fixture(scope="module")
def tracked() -> list[str]:
    return git_tracked()


def sizes(paths: list[str]) -> dict[str, int]:
    """Bytes of each tracked file present in the work tree (a file deleted
    but not yet staged is not counted)."""
    full = {p: os.path.join(ROOT, p) for p in paths}
    return {p: os.path.getsize(f) for p, f in full.items() if os.path.isfile(f)}


def test_no_generated_meshes_outside_scenarios(tracked):
    """Shipped meshes and hand-written test fixtures only (tests/data)."""
    meshes = [
        p
        for p in tracked
        if p.lower().endswith(".obj")
        and not p.startswith(("scenarios/", "tests/data/"))
    ]
    assert not meshes, f"{len(meshes)} meshes tracked outside scenarios/: {meshes[:5]}"


def test_at_most_a_thousand_files(tracked):
    assert 0 < len(tracked) <= MAX_FILES, f"{len(tracked)} files tracked"


def test_at_most_25_mb_in_all_and_2_mb_a_file(tracked):
    size = sizes(tracked)
    total = sum(size.values())
    assert total <= MAX_TOTAL_BYTES, f"{total / 1e6:.1f} MB tracked"
    big = {p: s for p, s in size.items() if s > MAX_FILE_BYTES}
    assert not big, f"files over 2 MB: {big}"


MAX_README_LINES = 300  # the README is a front door
# A docs page is a reference, not a diary; 400 lines left four pages
# squeezed to exactly 400 (issue 52: "no cap is gamed"): 600 lets a page say
# what it needs, and a page that needs more is two pages.
MAX_DOC_LINES = 600


def test_the_readme_and_every_docs_page_stay_short(tracked):
    # The CHANGELOG is the one diary: it grows by a section a release.
    pages = {
        p: MAX_DOC_LINES for p in tracked if p.endswith(".md") and p != "CHANGELOG.md"
    }
    pages["README.md"] = MAX_README_LINES
    long = {}
    for page, limit in pages.items():
        with open(os.path.join(ROOT, page)) as f:
            lines = sum(1 for _ in f)
        if lines > limit:
            long[page] = lines
    assert not long, f"pages over their limit (README 300, others 600): {long}"


def test_every_public_name_is_in_the_api_reference_and_it_is_linked():
    import mfi_drake

    with open(os.path.join(ROOT, "docs", "api.md")) as f:
        reference = f.read()
    # Each name where it is defined: in code quotes, followed by its
    # signature, the closing quote or an attribute.
    missing = [
        name
        for name in mfi_drake.__all__
        if not re.search(rf"`{re.escape(name)}[`(.]", reference)
    ]
    assert not missing, f"docs/api.md does not document {missing}"
    for page in ("README.md", os.path.join("docs", "usage.md")):
        with open(os.path.join(ROOT, page)) as f:
            assert "api.md)" in f.read(), f"{page} does not link docs/api.md"


def test_every_relative_link_of_a_page_names_a_file(tracked):
    broken = []
    for page in (p for p in tracked if p.endswith(".md")):
        with open(os.path.join(ROOT, page)) as f:
            text = f.read()
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not os.path.exists(os.path.join(ROOT, os.path.dirname(page), target)):
                broken.append((page, target))
    assert not broken, f"links to no file: {broken}"
