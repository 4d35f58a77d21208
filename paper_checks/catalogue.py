"""Read the IDs of ``CLAIMS.md`` (the paper's catalogue) and of ``EXTENSIONS.md`` (what
the project derives beyond the paper, IDs ``X...``) from their tables, so that a missing
check is a failure."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

CLAIMS = Path(__file__).with_name("CLAIMS.md")
EXTENSIONS = Path(__file__).with_name("EXTENSIONS.md")
_ID = re.compile(r"^([ECROX])(\d+)(?:\.(\d+)([a-z]?))?$")


@dataclass(frozen=True)
class Entry:
    id: str
    section: int
    what: str
    kind: str


def _expand(cell: str) -> list[str]:
    """``E3.2–E3.4`` -> E3.2, E3.3, E3.4; ``E3.5, E3.6`` -> E3.5, E3.6."""
    out: list[str] = []
    for part in (p.strip() for p in cell.split(",")):
        if "–" in part or "-" in part:
            lo, hi = re.split(r"[–-]", part)
            a, b = _ID.match(lo.strip()), _ID.match(hi.strip())
            if not (a and b and a.group(1) == b.group(1) and a.group(2) == b.group(2)):
                raise ValueError(f"catalogue: cannot expand the range {part!r}")
            out += [f"{a.group(1)}{a.group(2)}.{k}"
                    for k in range(int(a.group(3)), int(b.group(3)) + 1)]
        elif _ID.match(part):
            out.append(part)
        else:
            raise ValueError(f"catalogue: {part!r} is not an ID")
    return out


def entries(path: Path | None = None) -> list[Entry]:
    """The entries of ``path``, or of ``CLAIMS.md`` then ``EXTENSIONS.md``."""
    if path is None:
        return entries(CLAIMS) + entries(EXTENSIONS)
    rows: list[Entry] = []
    for line in path.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not line.startswith("| ") or cells[0] == "ID":
            continue
        if not _ID.match(cells[0].split(",")[0].split("–")[0].strip()):
            continue
        for eid in _expand(cells[0]):
            section = int(_ID.match(eid).group(2))
            rows.append(Entry(eid, section, cells[1], cells[-1]))
    return rows
