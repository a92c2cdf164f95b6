"""The session check of tests/conftest.py that no test or fixture writes into the checkout: what
it sees (a file written, created or removed; not the tools' caches), and that this session's
checkout is unchanged so far."""

import os

from tests.conftest import checkout_changes, checkout_files


def test_it_sees_files_written_created_and_removed_but_not_caches(tmp_path):
    (tmp_path / "kept.py").write_text("a")
    (tmp_path / "edited.py").write_text("a")
    (tmp_path / "gone.py").write_text("a")
    before = checkout_files(tmp_path)
    (tmp_path / "edited.py").write_text("b")
    os.utime(tmp_path / "edited.py", ns=(1, 1))
    (tmp_path / "gone.py").unlink()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "cells.jsonl").write_text("{}")
    for cache in ("__pycache__", ".hypothesis", ".git"):
        (tmp_path / cache).mkdir()
        (tmp_path / cache / "x").write_text("")
    assert checkout_changes(before, checkout_files(tmp_path)) == [
        "edited.py (written)",
        "gone.py (removed)",
        f"out{os.sep}cells.jsonl (created)",
    ]
