"""Executable denoisers: any program, in any language, behind the Denoiser interface.

FBKSD (Santos, Sen and Oliveira 2018) runs a denoiser given as an executable plus a small
manifest beside the shipped ones; so does bnerr. :func:`denoiser_class` reads a manifest and
returns a :class:`~denoisers.base.Denoiser` subclass whose :meth:`~ExternalDenoiser.denoise`
writes the frame's buffers as EXR files to a private temporary folder, runs the program on them
and reads back the image it wrote.

The manifest (TOML, ``*.toml``, read with :mod:`tomllib`; or JSON, ``*.json``)::

    name = "my_denoiser"                      # registry name: a letter, then [A-Za-z0-9_.-]
    command = ["{python}", "denoise.py", "--color", "{color}", "--albedo", "{albedo}",
               "--sigma", "{sigma}", "--out", "{output}"]
    inputs = ["color", "albedo"]              # buffers written (default ["color"])
    kind = "filter"                           # default "filter", or "temporal" when temporal
    temporal = false                          # frames fed in order, previous output passed
    timeout_s = 300                           # per frame; the process group is then killed
    description = "..."                       # optional, free text

    [params]                                  # name -> default (int, float or string)
    sigma = 1.0

    [grid]                                    # optional tuning grid: name -> candidate values
    sigma = [0.5, 1.0, 2.0]

Unknown keys are refused (the message lists the known ones), every value's type is checked, and
a malformed file is reported with its line. ``command`` is a list of arguments (argv), never a
shell string; each argument may hold placeholders, ``{{`` and ``}}`` stand for literal braces:

- ``{python}``: the Python running bnerr (:data:`sys.executable`), so a Python script sees the
  same packages (numpy, OpenEXR, torch, ...);
- ``{color}``, ``{albedo}``, ``{normal}``, ``{depth}``, ``{motion}``, ``{object_id}``,
  ``{variance}``: the EXR file of that buffer; each must be listed in ``inputs``, and each input
  must be used;
- ``{output}``: where the program writes its result (required);
- ``{previous_output}`` (temporal manifests only): the EXR of the output returned for the
  previous frame of the sequence; an empty string on its first frame (after ``reset()``);
- ``{frame}``: the frame's index in its sequence (the ``t`` the caller gave, else the count of
  frames denoised since ``reset()``);
- ``{NAME}``: the value of parameter ``NAME`` (``str(value)``: ``1.5``, ``3``, ``text``).

**Paths.** The program runs with the manifest's folder as its working directory, so relative
paths in ``command`` are relative to the manifest. The program's own file (``command[0]``, or
``command[1]`` when ``command[0]`` is ``{python}`` and ``command[1]`` does not start with ``-``)
is checked when the manifest is read: given as a relative path, it must exist and lie inside the
manifest's folder once ``..`` and symlinks are resolved (a path that escapes is refused); given
as an absolute path it is taken as the user wrote it; a bare ``command[0]`` with no ``/``
(``oidnDenoise``) is looked up on ``PATH``. Only that path is checked: arguments are data.

**Files.** Each input buffer is written to its own EXR file (float32, linear, ZIP compressed),
with the channel names of :data:`bnerr.io.CHANNELS` (``color``: ``R G B``; ``albedo``:
``albedo.R albedo.G albedo.B``; ``normal``: ``normal.X normal.Y normal.Z``; ``depth``:
``depth.Z``; ``motion``: ``motion.X motion.Y``). The output must be a single-part EXR of the
frame's size holding exactly the channels ``R G B``, FLOAT or HALF, all finite; a file of more
than four times the bytes of an uncompressed float32 image (plus 64 KiB) is refused before it is
read. It comes back as float32 ``[3, H, W]`` on the frame's device. The temporary folder is
removed after every frame, on success and on failure.

**Errors.** A bad manifest raises :class:`ManifestError` (a :class:`~bnerr.errors.FileFormatError`
naming the file); a program that fails (will not start, exits non-zero, runs past ``timeout_s``,
writes no output or a wrong one) raises :class:`~bnerr.errors.ExternalProcessError`, whose first
line names the denoiser, its command and what was expected, followed by the last 20 lines of the
program's stderr (of its stdout when stderr is empty). A run past ``timeout_s`` kills the
program's whole process group (it runs in a session of its own); so does its exit, for what it
left running in the background.

**Cost.** The sweep times ``denoiser(frame)`` (:mod:`benchmarks.sweep.measure`), so the cost
recorded for an external denoiser is the whole call: writing its inputs, starting the program
(a Python interpreter's start-up, its imports), its run and reading its output, which is what
using it costs.
"""

from __future__ import annotations

import inspect
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import ClassVar

import numpy as np
import torch

from bnerr.errors import DtypeError, ExternalProcessError, UnknownNameError
from bnerr.external import (
    ManifestError,
    command_placeholders,
    log_tail,
    program_error,
    read_manifest,
    resolve_program,
    run_program,
)
from bnerr.frame import Frame
from bnerr.io import openexr_quiet, write_exr
from bnerr.schemas.denoiser import FIXED_PLACEHOLDERS, coerce
from bnerr.schemas.denoiser import DenoiserManifestDocument as Document
from bnerr.schemas.manifest import FRAME_BUFFERS
from denoisers.base import Denoiser
from denoisers.temporal import check_continues

__all__ = [
    "BUFFER_INPUTS",
    "ExternalDenoiser",
    "MANIFEST_KEYS",
    "Manifest",
    "ManifestError",
    "denoiser_class",
    "load_manifest",
    "program_file",
    "run_manifest",
]

#: Buffers a manifest may list in ``inputs`` (and use as placeholders).
BUFFER_INPUTS: tuple[str, ...] = FRAME_BUFFERS

#: Every key a manifest may hold, with its default (``...``: required; ``kind`` None: "temporal"
#: for a temporal manifest, else "filter").
MANIFEST_KEYS: dict[str, object] = {
    key: ... if field.is_required() else field.default
    for key, field in Document.model_fields.items()
}
_SIZE_FACTOR = 4
_SIZE_SLACK = 64 * 1024


@dataclass(frozen=True)
class Manifest:
    """A checked manifest (see the module docstring); ``command`` has the program's path made
    absolute where it was given relative."""

    path: Path
    name: str
    command: tuple[str, ...]
    inputs: tuple[str, ...]
    params: Mapping[str, int | float | str]
    grid: Mapping[str, tuple[int | float | str, ...]]
    temporal: bool
    timeout_s: float
    kind: str
    description: str

    @property
    def folder(self) -> Path:
        """The manifest's folder: the program's working directory."""
        return self.path.parent


# ------------------------------------------------------------------------------------------------
# Reading the manifest


def _command(path: Path, doc: Document) -> list[str]:
    """The command with its placeholders checked (each input's buffer, ``{output}``, the
    parameters; ``{previous_output}`` when temporal) and its program's path resolved."""
    known = {*FIXED_PLACEHOLDERS, *BUFFER_INPUTS, *doc.params}
    if doc.temporal:
        known.add("previous_output")
    used = command_placeholders(path, doc.command, known)
    if "output" not in used:
        raise ManifestError(f"{path}: command: expected an {{output}} placeholder, got none")
    buffers = used & set(BUFFER_INPUTS)
    if buffers != set(doc.inputs):
        raise ManifestError(
            f"{path}: command: expected a placeholder for each of inputs = "
            f"{', '.join(doc.inputs)} and no other buffer, got {', '.join(sorted(buffers))}"
        )
    return resolve_program(path, list(doc.command))


def load_manifest(manifest_path: str | os.PathLike) -> Manifest:
    """Read and check a denoiser manifest (see the module docstring for its keys).

    Raises:
        DtypeError: ``manifest_path`` is not a path.
        ManifestError: the file is missing, malformed (with the line), holds an unknown key or a
            value of the wrong type, or its program is missing or escapes its folder.
    """
    if not isinstance(manifest_path, (str, os.PathLike)):
        raise DtypeError(
            f"manifest_path: expected a str or os.PathLike, got {type(manifest_path).__name__}"
        )
    path = Path(manifest_path).absolute()
    if not path.is_file():
        raise ManifestError(f"{path}: expected a denoiser manifest file, got no such file")
    doc = read_manifest(path, Document, "manifest")
    grid = {k: tuple(coerce(v, doc.params[k], "") for v in vs) for k, vs in doc.grid.items()}
    return Manifest(
        path=path,
        name=doc.name,
        command=tuple(_command(path, doc)),
        inputs=doc.inputs,
        params=MappingProxyType(dict(doc.params)),
        grid=MappingProxyType(grid),
        temporal=doc.temporal,
        timeout_s=doc.timeout_s,
        kind=doc.kind if doc.kind is not None else ("temporal" if doc.temporal else "filter"),
        description=doc.description,
    )


# ------------------------------------------------------------------------------------------------
# Running the program


def _failure(
    manifest: Manifest, argv: Sequence[str], expected: str, got: str, log: str = ""
) -> ExternalProcessError:
    """The ExternalProcessError of one failed frame: one line, then the program's log tail."""
    return program_error(
        f"denoiser {manifest.name!r} ({manifest.path.name})", argv, expected, got, log
    )


def _execute(manifest: Manifest, argv: list[str], work: Path) -> None:
    """Run ``argv`` in the manifest's folder, in a session of its own, with the time limit."""
    what = f"denoiser {manifest.name!r} ({manifest.path.name})"
    run_program(what, argv, cwd=manifest.folder, timeout_s=manifest.timeout_s, work=work)


def program_file(manifest: Manifest) -> Path | None:
    """The file the manifest's command runs (its program, or the script after ``{python}``),
    once resolved against the manifest's folder; None for a program found on ``PATH`` or
    ``{python} -m``. Its bytes are part of the plug-in's fingerprint, so that ``--resume``
    sees an edited program behind an unchanged manifest."""
    for arg in manifest.command[:2]:
        if os.path.isabs(arg) and os.path.isfile(arg):
            return Path(arg)
    return None


def _exr_header(path: Path) -> tuple[tuple[int, int], list[str]]:
    """The ``(height, width)`` and sorted channel names of an EXR file, its pixels unread."""
    import OpenEXR

    if not OpenEXR.isOpenExrFile(str(path)):
        raise ValueError("no EXR magic number")
    header = OpenEXR.File(str(path), header_only=True).header()
    low, high = header["dataWindow"]
    size = (int(high[1] - low[1] + 1), int(high[0] - low[0] + 1))
    return size, sorted(channel.name for channel in header["channels"])


def _exr_planes(path: Path) -> list[np.ndarray]:
    """The ``R``, ``G`` and ``B`` planes of an EXR file, in their stored dtype."""
    import OpenEXR

    channels = OpenEXR.File(str(path), separate_channels=True).channels()
    return [np.asarray(channels[c].pixels) for c in ("R", "G", "B")]


def _read_output(
    manifest: Manifest, argv: list[str], path: Path, size: tuple[int, int]
) -> torch.Tensor:
    """The program's output EXR as float32 ``[3, H, W]`` after checking it (module docstring):
    its byte size and header before its pixels, then their type and finiteness."""

    def fail(expected: str, got: str) -> ExternalProcessError:
        return _failure(manifest, argv, expected, got, log_tail(path.parent))

    if not path.is_file():
        raise fail(f"an output EXR at {{output}} ({path.name})", "no such file")
    height, width = size
    limit = _SIZE_FACTOR * height * width * 3 * 4 + _SIZE_SLACK
    if path.stat().st_size > limit:
        raise fail(f"an output EXR of at most {limit} bytes", f"{path.stat().st_size} bytes")
    said: list[str] = []
    try:
        with openexr_quiet(path) as said:  # OpenEXR's own lines go into the one error line
            got_size, names = _exr_header(path)
            if got_size != size:
                raise fail(
                    f"an output of {width} x {height} pixels (width x height)",
                    f"{got_size[1]} x {got_size[0]}",
                )
            if names != ["B", "G", "R"]:
                raise fail("the output channels R, G, B only", ", ".join(names) or "none")
            planes = _exr_planes(path)
    except ExternalProcessError:
        raise
    except Exception as error:  # the binding raises RuntimeError or ValueError on corrupt data
        reason = str(error).splitlines()[0] if str(error) else ""
        quoted = f"; OpenEXR said: {said[0]}" if said and said[0] else ""
        raise fail("an OpenEXR output", f"{type(error).__name__}: {reason}{quoted}") from None
    if any(p.dtype not in (np.float32, np.float16) for p in planes):
        raise fail("FLOAT or HALF output channels", ", ".join(str(p.dtype) for p in planes))
    out = torch.from_numpy(np.stack([p.astype(np.float32) for p in planes]))
    bad = int((~torch.isfinite(out)).sum())
    if bad:
        raise fail("finite output values", f"{bad} NaN or infinite of {out.numel()}")
    return out


def _inputs_written(
    manifest: Manifest, frame: Frame, work: Path, previous: torch.Tensor | None
) -> dict[str, str]:
    """Write each input (and the previous output) as an EXR; the file placeholders' values."""
    files: dict[str, str] = {"output": str(work / "output.exr")}
    for name in manifest.inputs:
        target = work / f"{name}.exr"
        write_exr(target, {name: getattr(frame, name).detach().float().cpu()})
        files[name] = str(target)
    if manifest.temporal:
        files["previous_output"] = ""
        if previous is not None:
            target = work / "previous_output.exr"
            write_exr(target, {"color": previous.detach().float().cpu()})
            files["previous_output"] = str(target)
    return files


def run_manifest(
    manifest: Manifest,
    params: Mapping[str, object],
    frame: Frame,
    index: int,
    previous: torch.Tensor | None = None,
) -> torch.Tensor:
    """Denoise ``frame`` with the manifest's program: write its inputs to a private temporary
    folder, run the command with ``params`` and ``index`` in its placeholders, read and check
    the output; the folder is removed whatever happens. Returns float32 ``[3, H, W]`` on the
    frame's device.

    Raises:
        ExternalProcessError: the program failed, or its output is missing or wrong.
    """
    work = Path(tempfile.mkdtemp(prefix=f"bnerr-{manifest.name}-"))
    try:
        values = {str(k): str(v) for k, v in params.items()}
        values.update(_inputs_written(manifest, frame, work, previous))
        values.update(python=sys.executable, frame=str(index))
        argv = [arg.format(**values) for arg in manifest.command]
        _execute(manifest, argv, work)
        out = _read_output(manifest, argv, Path(values["output"]), (frame.height, frame.width))
        return out.to(frame.color.device)
    finally:
        shutil.rmtree(work, ignore_errors=True)


# ------------------------------------------------------------------------------------------------
# The Denoiser class


class ExternalDenoiser(Denoiser):
    """Base of the classes :func:`denoiser_class` makes: one per manifest (``manifest``).

    Built with keyword parameters (the manifest's ``[params]``, defaults filled in; an int is
    accepted for a float). A temporal manifest makes a stateful denoiser: :meth:`reset` starts a
    sequence, frames must come in order, and the previous output is passed to the program.
    """

    manifest: ClassVar[Manifest]
    kind: ClassVar[str] = "filter"
    grid: ClassVar[Mapping[str, Sequence[object]]] = MappingProxyType({})

    def __init__(self, **params: object) -> None:
        defaults = self.manifest.params
        unknown = sorted(set(params) - set(defaults))
        if unknown:
            raise UnknownNameError(
                f"denoiser {self.name!r}: unknown parameter(s) {', '.join(unknown)}: expected "
                f"one of {', '.join(defaults) or '(none)'}"
            )
        self._params = {
            key: coerce(params.get(key, default), default, f"denoiser {self.name!r}: {key}")
            for key, default in defaults.items()
        }
        self.reset()

    def reset(self) -> None:
        """Forget the sequence: the next frame is frame 0 and has no previous output."""
        self._previous: torch.Tensor | None = None
        self._t: int | None = None
        self._count = 0
        self._index = 0

    def _check_sequence(self, frame: Frame, t: int | None) -> None:
        if self.stateful:
            before = None if self._previous is None else self._previous.shape
            check_continues(f"denoiser {self.name!r}", before, frame.color.shape, self._t, t)
            self._t = t
        self._index = t if t is not None else self._count

    def denoise(self, frame: Frame) -> torch.Tensor:
        out = run_manifest(self.manifest, self._params, frame, self._index, self._previous)
        self._count += 1
        if self.stateful:
            self._previous = out
        return out

    def params(self) -> dict[str, float | int | str]:
        return dict(self._params)

    def __reduce__(self) -> tuple[object, ...]:
        # the class is made at run time: rebuild it from its manifest in another process
        return (_rebuild, (str(self.manifest.path), self.params()))


def _rebuild(manifest_path: str, params: dict) -> Denoiser:
    return denoiser_class(manifest_path)(**params)


def denoiser_class(manifest_path: str | os.PathLike) -> type[Denoiser]:
    """A :class:`~denoisers.base.Denoiser` subclass that runs the program ``manifest_path``
    declares (see the module docstring).

    The class has ``name``, ``requires`` (the inputs but color), ``stateful`` (``temporal``),
    ``kind``, ``grid`` and ``manifest``; its ``__init__`` takes the manifest's parameters as
    keywords, so :func:`denoisers.get_denoiser` builds it once it is registered in
    :data:`denoisers.DENOISERS`.

    Raises:
        ManifestError: as :func:`load_manifest`.
    """
    manifest = load_manifest(manifest_path)

    def __init__(self: ExternalDenoiser, **params: object) -> None:
        ExternalDenoiser.__init__(self, **params)

    keyword = inspect.Parameter.KEYWORD_ONLY
    __init__.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
        + [inspect.Parameter(k, keyword, default=v) for k, v in manifest.params.items()]
    )
    attributes = {
        "__init__": __init__,
        "__module__": __name__,
        "__doc__": manifest.description or f"The external denoiser of {manifest.path}.",
        "name": manifest.name,
        "requires": frozenset(manifest.inputs) - {"color"},
        "stateful": manifest.temporal,
        "kind": manifest.kind,
        "grid": manifest.grid,
        "manifest": manifest,
    }
    title = "".join(part.capitalize() for part in re.split(r"[^A-Za-z0-9]+", manifest.name))
    return type(f"External{title}", (ExternalDenoiser,), attributes)
