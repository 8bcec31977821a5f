"""Links between the docs resolve: every relative link and image in README.md and docs/*.md names a file that exists,
and every section a doc cites by name in another doc ('RESULTS.md, "Starvation"') is a heading of that doc (or the
bold name that opens one of its paragraphs)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DOCUMENTS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
#: 'EXPERIMENTS.md, "Claims"', 'docs/RESULTS.md "Starvation"' (the section's name, or the start of it, in quotes).
SECTION = re.compile(r"\b((?:docs/)?[A-Z_]+\.md)\)?,? \"([^\"]+)\"")


def fenced_code_removed(text: str) -> str:
    return re.sub(r"^```.*?^```", "", text, flags=re.MULTILINE | re.DOTALL)


def headings(document: Path) -> list[str]:
    """The document's headings, and the bold names that open a paragraph ('**The law on late ticks** (...)')."""
    text = fenced_code_removed(document.read_text())
    return re.findall(r"^#+ (.+)$", text, re.MULTILINE) + re.findall(r"^\*\*([^*]+)\*\*", text, re.MULTILINE)


def document_named(name: str) -> Path:
    name = name.removeprefix("docs/")
    return REPO / name if name == "README.md" else REPO / "docs" / name


@pytest.mark.parametrize("document", DOCUMENTS, ids=[d.name for d in DOCUMENTS])
def test_every_relative_link_resolves(document: Path):
    missing = []
    for target in LINK.findall(fenced_code_removed(document.read_text())):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue
        path = (document.parent / target.split("#")[0]).resolve()
        if not path.exists():
            missing.append(target)
    assert not missing, f"{document.name}: links to nothing: {missing}"


@pytest.mark.parametrize("document", DOCUMENTS, ids=[d.name for d in DOCUMENTS])
def test_every_cited_section_is_a_heading_of_its_document(document: Path):
    text = " ".join(fenced_code_removed(document.read_text()).split())
    missing = []
    for name, section in SECTION.findall(text):
        cited = document_named(name)
        if not cited.exists():
            missing.append(f"{name} (no such document)")
        elif not any(heading.startswith(section.rstrip(". ")) for heading in headings(cited)):
            missing.append(f'{name}, "{section}"')
    assert not missing, f"{document.name} cites sections that do not exist: {missing}"


def test_the_checks_find_a_broken_link_and_a_missing_section(tmp_path):
    """The machinery itself: a link to no file and a section no document has are both caught."""
    assert LINK.findall("see [x](nowhere.md) and ![p](../results/none.png)") == ["nowhere.md", "../results/none.png"]
    found = SECTION.findall('docs/RESULTS.md, "No such section" and EXPERIMENTS.md "Claims"')
    assert found == [("docs/RESULTS.md", "No such section"), ("EXPERIMENTS.md", "Claims")]
    assert not any(h.startswith("No such section") for h in headings(REPO / "docs" / "RESULTS.md"))
