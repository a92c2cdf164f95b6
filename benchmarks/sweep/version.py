"""The code version of the references: a hash of the source files a reference's pixels depend on.

:func:`code_version` is ``0-<source hash>``: 12 hex digits of SHA-256 over the source files of
:func:`reference_sources`: every ``.py`` of ``renderers``, of the ``bnerr.sequences`` module (its
file, or every ``.py`` under its package directory) and ``bnerr/hashing.py``. It enters every
reference's cache key (:class:`benchmarks.sweep.references.ReferenceCache`), every record
(``Record.reference.version``) and the Ray tasks' check that a node runs the driver's code.

:func:`device_info` says what a record measured off the CPU was measured on (the device, its
name, torch's and CUDA's versions): GPU numbers differ from CPU ones in the last bits and in
every timing, so the records say so and a resumed sweep does not mix them.

A leaf: :class:`benchmarks.sweep.parts.Parts` carries the version and the reference cache reads
it, so both import this module and neither imports the other for it.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
from pathlib import Path

import torch

__all__ = ["code_version", "device_info", "reference_sources", "source_hash"]

# The modules whose source a reference's pixels depend on (besides its own seeds).
_SOURCE_MODULES = ("renderers", "bnerr.sequences", "bnerr.hashing")


def _module_files(name: str) -> dict[str, Path]:
    """A module's ``.py`` files (every one under a package's directory), keyed by their path
    relative to the top-level package's parent (``bnerr/hashing.py``)."""
    module = importlib.import_module(name)
    top = Path(inspect.getfile(importlib.import_module(name.split(".")[0]))).parent.parent
    file = Path(inspect.getfile(module))
    files = sorted(file.parent.rglob("*.py")) if file.name == "__init__.py" else [file]
    return {f.relative_to(top).as_posix(): f for f in files}


def reference_sources() -> dict[str, Path]:
    """The source files a reference's pixels depend on: label (``renderers/tracer.py``) -> path."""
    sources: dict[str, Path] = {}
    for name in _SOURCE_MODULES:
        sources.update(_module_files(name))
    return sources


def source_hash(sources: dict[str, Path]) -> str:
    """12 hex digits of SHA-256 over the files' labels and bytes, in label order."""
    digest = hashlib.sha256()
    for label in sorted(sources):
        digest.update(label.encode())
        digest.update(sources[label].read_bytes())
    return digest.hexdigest()[:12]


def code_version(sources: dict[str, Path] | None = None) -> str:
    """``0-<source hash>`` of the references' code (default :func:`reference_sources`).

    The ``0-`` is what a ``renderers.RENDERER_VERSION`` hook gave when none was declared, and none
    ever was; the hook is gone (the source hash covers every change it could have announced), the
    prefix stays so that cached references and recorded versions keep their keys.
    """
    files = reference_sources() if sources is None else sources
    return f"0-{source_hash(files)}"


def device_info(device: str) -> dict[str, str] | None:
    """What a record measured on ``device`` says of it: None on the CPU (the records' default:
    CPU records stay as they were), else ``{"device": "cuda:0", "name": <the GPU's name>,
    "torch": torch.__version__, "cuda": torch.version.cuda}``."""
    where = torch.device(device)
    if where.type == "cpu":
        return None
    if where.type == "cuda" and where.index is None:
        where = torch.device("cuda", torch.cuda.current_device())
    name = torch.cuda.get_device_name(where) if where.type == "cuda" else where.type
    cuda = torch.version.cuda or ""
    return {"device": str(where), "name": name, "torch": torch.__version__, "cuda": cuda}
