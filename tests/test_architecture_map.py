"""The house's map: docs/ARCHITECTURE.md names every module of the four packages."""

from __future__ import annotations

import re
from pathlib import Path

from tests._paths import ROOT

PACKAGES = ("bnerr", "renderers", "denoisers", "benchmarks")


def architecture_map(text: str) -> dict[str, set[str]]:
    """Package -> the module paths (relative to it) that docs/ARCHITECTURE.md's file map names
    in its section ``## <package>``: backticked ``name.py`` or ``sub/name.py``, a bare name after
    ``sub/...`` in the same row or bullet taking that folder, and a subpackage as ``sub/``."""
    found: dict[str, set[str]] = {p: set() for p in PACKAGES}
    section, prefix = None, ""
    for line in text.splitlines():
        head = re.match(r"## (\w+)", line)
        if head:
            section = head.group(1) if head.group(1) in PACKAGES else None
            continue
        if section is None:
            continue
        if line.startswith(("- ", "|")):
            prefix = ""
        for token in re.findall(r"`([^`\s]+)`", line):
            token = token.removeprefix(f"{section}/")
            if token.endswith("/"):
                prefix = token
                found[section].add(token)
            elif token.endswith(".py") and "/" in token:
                prefix = token.rsplit("/", 1)[0] + "/"
                found[section].add(token)
            elif token.endswith(".py"):
                found[section].update({token, prefix + token})
    return found


def test_architecture_map_reads_rows_bullets_and_folders():
    text = "## bnerr\n| `io.py` | x |\n| `ldbn/` | `keys.py`, `swaps.py` |\n- `sub/a.py`, `b.py`\n"
    assert architecture_map(text)["bnerr"] == {
        "io.py", "ldbn/", "keys.py", "ldbn/keys.py", "swaps.py", "ldbn/swaps.py",
        "sub/a.py", "b.py", "sub/b.py",
    }  # fmt: skip


def test_the_architecture_file_map_names_every_module():
    found = architecture_map((ROOT / "docs/ARCHITECTURE.md").read_text(encoding="utf-8"))
    missing = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            relative = path.relative_to(ROOT / package)
            if relative.name == "__init__.py":
                key = f"{relative.parent}/" if relative.parent != Path(".") else None
            else:
                key = str(relative)
            if key is not None and key not in found[package]:
                missing.append(f"{package}/{key}")
    assert not missing, "docs/ARCHITECTURE.md's file map omits:\n" + "\n".join(missing)
