"""Fixtures of the sweep tests: one reference cache for the end-to-end ordering files."""

import pytest


@pytest.fixture(scope="session")
def shared_references(request, tmp_path_factory):
    """A reference cache shared by every test of the session, and by every xdist worker of it (the
    folder above the workers' own temporary folders, fresh for each run): the ordering files
    render the same references (direct, indirect and snooker at 128x128, 256 spp), and the cache
    writes each file atomically, so two workers that miss the same one at once both write it
    whole."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if hasattr(request.config, "workerinput") else base
    folder = root / "shared-references"
    folder.mkdir(exist_ok=True)
    return folder
