"""docs/claims.md, the status of every numbered claim of the five source extractions (issue 29).

(a) every claim ID of the claim tables of ``../shared/notes/seed-00N-*.md`` is a row of its source's section of
docs/claims.md (skipped where the notes are absent, e.g. a fresh clone in CI); (b) every test cited there as
``tests/...py::test_name`` exists; (c) every status is one of the four words, and the summary table counts the rows.
Reads text only: well under a second.
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CLAIMS = ROOT / "docs" / "claims.md"
NOTES = ROOT.parent / "shared" / "notes"
SOURCES = ("seed-000", "seed-001", "seed-002", "seed-003", "seed-004")
STATUSES = ("reproduced", "refuted", "not reproduced", "not addressed")

#: the heading of an extraction's claim list: "## 17. Concrete testable claims ...", "## 7. Testable claims ..."
CLAIM_HEADING = re.compile(r"^## \d+\.\s.*testable claims", re.I | re.M)
#: an ID where the extractions put one: first cell of a table row ("| P6 | ..."), start of a bullet ("- **T24: ..."
#: or "- **T24 (real data ...") or start of a line ("T6 [DER] ...", seed-000)
NOTE_ID = re.compile(r"^(?:\|\s*|- \*\*)?([A-Z]\d{1,2})(?=\s*\||[:\s])", re.M)
NODE_ID = re.compile(r"(tests/[\w/]+\.py)::(\w+)")


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _sections() -> dict[str, str]:
    """docs/claims.md split at its level-2 headings, keyed by the source ("seed-000") the heading names."""
    text = CLAIMS.read_text(encoding="utf-8")
    parts = re.split(r"^## ", text, flags=re.M)
    out = {}
    for part in parts[1:]:
        m = re.match(r"(seed-\d{3})\b", part)
        if m:
            assert m.group(1) not in out, f"two sections for {m.group(1)}"
            out[m.group(1)] = part
    return out


def _claim_rows(section: str) -> list[list[str]]:
    return [_cells(line) for line in section.splitlines() if re.match(r"^\|\s*[A-Z]\d{1,2}\s*\|", line)]


def _note_ids(path: Path) -> list[str]:
    """The claim IDs of one extraction: its "testable claims" section up to the next level-2 heading."""
    text = path.read_text(encoding="utf-8")
    start = CLAIM_HEADING.search(text)
    assert start, f"{path.name}: no '## N. ... testable claims' section"
    end = re.search(r"^## ", text[start.end():], flags=re.M)
    body = text[start.end(): start.end() + end.start()] if end else text[start.end():]
    ids = NOTE_ID.findall(body)
    assert ids, f"{path.name}: no claim IDs found"
    return list(dict.fromkeys(ids))


def test_every_source_has_one_section_of_six_column_rows_without_duplicates():
    sections = _sections()
    assert set(sections) == set(SOURCES)
    for src, body in sections.items():
        rows = _claim_rows(body)
        assert rows, src
        assert all(len(r) == 6 for r in rows), [(src, r[0], len(r)) for r in rows if len(r) != 6]
        ids = [r[0] for r in rows]
        assert len(ids) == len(set(ids)), (src, [i for i, n in Counter(ids).items() if n > 1])


@pytest.mark.skipif(not NOTES.is_dir(), reason=f"the extractions are not here ({NOTES}): a clone without ../shared")
@pytest.mark.parametrize("source", SOURCES)
def test_every_claim_of_the_extraction_has_a_row(source):
    notes = sorted(NOTES.glob(f"{source}-*.md"))
    assert len(notes) == 1, (source, notes)
    want = _note_ids(notes[0])
    have = [r[0] for r in _claim_rows(_sections()[source])]
    missing = [i for i in want if i not in have]
    extra = [i for i in have if i not in want]
    assert not missing and not extra, f"{source}: missing {missing}, not in the extraction {extra}"


def test_every_cited_test_exists():
    text = CLAIMS.read_text(encoding="utf-8")
    cited = sorted(set(NODE_ID.findall(text)))
    assert cited
    bad = []
    for file, name in cited:
        path = ROOT / file
        if not path.is_file() or not re.search(rf"^\s*def {name}\(", path.read_text(encoding="utf-8"), re.M):
            bad.append(f"{file}::{name}")
    assert not bad, bad


def test_statuses_are_the_four_words_and_the_summary_counts_them():
    sections = _sections()
    counts = {}
    for src, body in sections.items():
        statuses = [r[4] for r in _claim_rows(body)]
        assert set(statuses) <= set(STATUSES), (src, set(statuses) - set(STATUSES))
        counts[src] = Counter(statuses)
    summary = CLAIMS.read_text(encoding="utf-8").split("## Summary", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in summary.splitlines():
        m = re.match(r"^\|\s*(seed-\d{3}|all)\b", line)
        if m:
            rows[m.group(1)] = [int(c) for c in _cells(line)[1:]]
    assert set(rows) == set(SOURCES) | {"all"}
    for src in SOURCES:
        c = counts[src]
        assert rows[src] == [sum(c.values())] + [c[s] for s in STATUSES], src
    assert rows["all"] == [sum(rows[s][k] for s in SOURCES) for k in range(5)]
