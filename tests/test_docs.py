"""References that resolve: every requirement id the code or the docs name is defined in
docs/REQUIREMENTS.md, and the README cites the thesis the section numbers point into."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
REQUIREMENTS = ROOT / "docs" / "REQUIREMENTS.md"
REQUIREMENT_ID = re.compile(r"\bR-[A-Z]+(?:-[A-Z]+)*\b")
REQUIREMENTS_SECTION = re.compile(r"REQUIREMENTS (§\d+)")


def _sources() -> list[Path]:
    """Every text file whose comments, docstrings or prose may name a requirement."""
    found = [
        path
        for folder in ("src", "tests", "docs", "bench", "deploy")
        for path in sorted((ROOT / folder).rglob("*"))
        if path.suffix in {".py", ".md", ".toml", ".dbc"}
        and "data" not in path.relative_to(ROOT).parts
        and path != REQUIREMENTS
    ]
    return [ROOT / "README.md", *found]


def _cited(pattern: re.Pattern[str]) -> dict[str, list[str]]:
    """What matches `pattern`, with the files that cite it."""
    cited: dict[str, list[str]] = {}
    for path in _sources():
        for match in set(pattern.findall(path.read_text(encoding="utf-8"))):
            cited.setdefault(match, []).append(str(path.relative_to(ROOT)))
    return cited


def _defined_ids() -> set[str]:
    text = REQUIREMENTS.read_text(encoding="utf-8")
    return set(re.findall(r"^- \*\*(R-[A-Z-]+)\*\*", text, flags=re.MULTILINE))


def test_every_requirement_id_cited_is_defined_in_docs_requirements() -> None:
    cited = _cited(REQUIREMENT_ID)
    assert "R-WATCHDOG" in cited  # the scan does find the ids: runtime/watchdog.py names one
    dangling = {name: files for name, files in cited.items() if name not in _defined_ids()}
    assert dangling == {}


def test_every_requirement_defined_is_cited_somewhere() -> None:
    assert _defined_ids() - set(_cited(REQUIREMENT_ID)) == set()


def test_every_requirements_section_cited_is_a_heading_of_docs_requirements() -> None:
    cited = _cited(REQUIREMENTS_SECTION)
    assert "§8" in cited  # the benchmark names its targets' section
    headings = re.findall(r"^## .*", REQUIREMENTS.read_text(encoding="utf-8"), flags=re.MULTILINE)
    dangling = {
        section: files
        for section, files in cited.items()
        if not any(f"REQUIREMENTS {section})" in heading for heading in headings)
    }
    assert dangling == {}


def test_the_readme_cites_the_thesis_and_links_the_requirements() -> None:
    readme = ROOT.joinpath("README.md").read_text(encoding="utf-8")
    references = readme.split("\n## References\n", 1)[1]
    for part in ("Rim Puks", "Low Level Controller Software", "Tallinn University of Technology"):
        assert part in references
    assert "2020" in references
    assert "(docs/REQUIREMENTS.md)" in references


SAFETY = ROOT / "docs" / "SAFETY.md"
SECURITY = ROOT / "docs" / "SECURITY.md"
TEST_REFERENCE = re.compile(r"`(tests/[\w/]+\.py)?(?:::(\w+))?`")


@pytest.mark.parametrize("document", [SAFETY, SECURITY], ids=lambda path: path.name)
def test_every_test_the_hazard_and_attack_tables_name_exists(document: Path) -> None:
    """`tests/x.py::test_y`, and `::test_z` after it for the same file, as SAFETY.md and
    SECURITY.md write them."""
    missing: list[str] = []
    current: Path | None = None
    for match in TEST_REFERENCE.finditer(document.read_text(encoding="utf-8")):
        file, test = match.groups()
        if file:
            current = ROOT / file
            if not current.is_file():
                missing.append(file)
                continue
        defined = rf"^(?:async )?def {test}\("
        if test and current and not re.search(defined, current.read_text("utf-8"), re.M):
            missing.append(f"{current.relative_to(ROOT)}::{test}")
    assert missing == []


def test_the_readme_can_table_reserves_the_error_report_bits_the_dbc_does() -> None:
    """Issue 32, defect 10: the README said bits 23-63 were reserved; bit 23 is CAN_AUTH_FAILED.
    Issue 35: the README names no bit numbers (a new flag would make it stale); the DBC's
    comment, rendered from the flags, names them."""
    from bywire.protocol.dbc import database  # noqa: PLC0415 -- only this test loads the DBC

    message = database().get_message_by_name("ErrorReport")
    first_free = max(signal.start + signal.length for signal in message.signals)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    row = next(line for line in readme.splitlines() if line.startswith("| 0x201 | ErrorReport"))
    assert "from bit 0 up; the bits above the last flag reserved" in row, row
    assert re.search(r"bits \d", row) is None, row  # no range of bits, which a flag would move
    assert f"bits {first_free}-63 are reserved" in (message.comment or "")
