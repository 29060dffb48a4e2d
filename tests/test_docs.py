"""The docs stay short enough to read: README and each guide within their words, all of them within 20,000."""

from __future__ import annotations

import pytest
from conftest import REPOSITORY

#: file -> most words (as ``wc -w`` counts them): README + the one guide a user needs read in 20 minutes
LIMITS = {
    "README.md": 1500,
    "docs/discovery.md": 2500,
    "docs/own-data.md": 2500,
    "docs/beyond.md": 2500,
    "docs/reproducibility.md": 2500,
}
TOTAL = 20_000  # README and every page of docs/ but the dated notes


def words(path) -> int:
    return len(path.read_text().split())


@pytest.mark.parametrize(("name", "limit"), LIMITS.items())
def test_a_guide_stays_within_its_words(name, limit):
    assert words(REPOSITORY / name) <= limit


def test_readme_and_docs_stay_within_their_words():
    pages = [REPOSITORY / "README.md", *sorted((REPOSITORY / "docs").glob("*.md"))]
    assert sum(map(words, pages)) <= TOTAL, {p.name: words(p) for p in pages}
