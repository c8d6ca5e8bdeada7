"""What the benchmarks that write their tables into docs/ share (run as scripts, so this is
imported from the scripts' folder)."""

from __future__ import annotations

from pathlib import Path


def write_section(doc: Path, section: str, lines: list[str]) -> None:
    """Replace the text between `section`'s markers (``<!-- begin section -->`` and
    ``<!-- end section -->``) in `doc` with `lines`."""
    begin, end = f"<!-- begin {section} -->", f"<!-- end {section} -->"
    text = doc.read_text()
    head, rest = text.split(begin + "\n")
    _, tail = rest.split(end)
    doc.write_text(head + begin + "\n" + "\n".join(lines) + "\n" + end + tail)
