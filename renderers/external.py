"""The seed protocol: any renderer, run as a program per frame, behind bnerr's render callback.

bnerr's strategies drive a renderer through ``render(seeds [H, W] int64, sampler) -> Frame``
(:class:`bnerr.strategies.RenderFn`). :class:`ExternalRenderer` implements it for a program
that knows nothing of Python: per frame it writes the per-pixel seeds to a *seed file*, runs the
program's command, reads back the OpenEXR frame it wrote and checks it. The oracle's K candidate
frames are K runs, or one run with a seed file of K images when the manifest says ``batch``.
docs/RENDERER_PROTOCOL.md is the user's page; this docstring is its reference.

**The seed file** (``{seeds}``): little-endian, a 24-byte header then the seeds::

    offset  type       value
    0       4 bytes    magic b"BNSD"
    4       uint32     version, 1
    8       uint32     width W
    12      uint32     height H
    16      uint32     count K of seed images (1 unless the manifest says batch)
    20      uint32     dtype of the seeds: 1 = uint32
    24      uint32     seeds [K][H][W], row-major (pixel (y, x) of image k at (k H + y) W + x)

A seed is the low 32 bits of bnerr's int64 seed (every bnerr sampler reads only those). With the
per-pixel sampler ``owen_sobol`` it seeds the pixel's Owen-scrambled Sobol sequence padded by 2D
pairs (:func:`bnerr.sequences.owen_sobol`; examples/native/tracer.c ports it bit for bit).

**The manifest** (TOML ``*.toml`` or JSON ``*.json``; :func:`load_renderer_manifest`)::

    name = "native"                   # the scene's name in the records and the reference cache
    command = ["./tracer", "--seeds", "{seeds}", "--spp", "{spp}", "--out", "{out}"]
    buffers = ["color", "albedo"]     # buffers each frame must hold (default ["color"])
    samplers = ["owen_sobol"]         # samplers it implements: owen_sobol, ldbn
    dimensions = 8                    # sampler dimensions one path takes (the scene's D)
    timeout_s = 60                    # per run; the process group is then killed
    batch = false                     # one run per seed file of K images ({out}: a folder)
    description = "..."

``command`` is argv (never a shell string) with placeholders: ``{seeds}`` (the seed file),
``{out}`` (the EXR to write; with ``batch``, a folder to write ``0.exr`` .. ``K-1.exr`` into),
``{spp}``, ``{frame}`` (the renderer's frame index), ``{width}``, ``{height}``, ``{sampler}``
(``owen_sobol`` or ``ldbn``), ``{python}`` (the Python running bnerr), and for ``ldbn``:
``{ldbn_keys}`` (the key set's name as ``bnerr export --ldbn`` writes it, e.g.
``ldbn_screen_64``), ``{ldbn_slice}`` (the slice of the exported array: ``level * F + frame``)
and ``{ldbn_offset_y}``, ``{ldbn_offset_x}`` (the frame's toroidal offset of the tiles; the
other samplers get ``none`` and zeros). ``{seeds}``, ``{out}`` and ``{spp}`` are required, and
``{sampler}`` and the four ``ldbn_`` ones when ``samplers`` lists ``ldbn``. The program runs in
the manifest's folder (a relative program path must lie inside it: :mod:`bnerr.external`).
:func:`command_manifest` makes the manifest of ``bnerr bench --renderer-cmd "TEMPLATE"``.

**The frame**: an OpenEXR file of ``W x H`` pixels (width x height, the order of ``--res`` and of
every size in bnerr's messages) with the channel names of :mod:`bnerr.io` (``R G B``;
``albedo.R ..``, ``normal.X ..``, ``depth.Z``, ``motion.X motion.Y``, ``object_id.Y``,
``variance.R ..``), FLOAT or HALF, every value finite; a file of more than four times the bytes
of 16 uncompressed float32 channels (plus 64 KiB) is refused before it is read. The buffers the
manifest lists must be there; the other Frame buffers present are kept. Its
``timings["render"]`` is the program's wall time (start to exit, milliseconds; a batch run's
divided by K): the render cost the records keep.

**Errors**: a bad manifest is a :class:`bnerr.external.ManifestError`; a program that fails
(will not start, exits non-zero, runs past ``timeout_s``, writes no frame or a wrong one) an
:class:`~bnerr.errors.ExternalProcessError` naming the renderer, its command and what was
expected, followed by the last lines of its stderr; a sampler the manifest does not list a
:class:`~bnerr.errors.ValueRangeError`.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import re
import shlex
import shutil
import struct
import sys
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from bnerr.errors import (
    DtypeError,
    ExternalProcessError,
    FileFormatError,
    ValueRangeError,
    check_dtype,
    check_finite,
    check_positive_int,
    check_shape,
)
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
from bnerr.hashing import MASK32
from bnerr.io import atomic_write, read_frame
from bnerr.schemas.errors import validate
from bnerr.schemas.manifest import FRAME_BUFFERS
from bnerr.schemas.renderer import SAMPLERS
from bnerr.schemas.renderer import RendererManifestDocument as Document

__all__ = [
    "PLACEHOLDERS",
    "RENDERER_KEYS",
    "SAMPLERS",
    "SEED_HEADER",
    "ExternalRenderer",
    "RendererManifest",
    "command_manifest",
    "load_renderer_manifest",
    "read_seed_file",
    "sampler_values",
    "write_seed_file",
]

#: The seed file's header: magic, version, width, height, count, dtype (1: uint32).
SEED_HEADER = struct.Struct("<4s5I")
_MAGIC, _VERSION, _UINT32 = b"BNSD", 1, 1

#: Every key a renderer manifest may hold, with its default (``...``: required).
RENDERER_KEYS: dict[str, object] = {
    key: ... if field.is_required() else field.default
    for key, field in Document.model_fields.items()
}
_LDBN_PLACEHOLDERS = ("ldbn_keys", "ldbn_slice", "ldbn_offset_y", "ldbn_offset_x")
#: Every placeholder a command may use.
PLACEHOLDERS: tuple[str, ...] = (
    *("python", "seeds", "spp", "frame", "out", "width", "height", "sampler"),
    *_LDBN_PLACEHOLDERS,
)
_REQUIRED = ("seeds", "out", "spp")
_SIZE_FACTOR, _SIZE_SLACK, _MAX_CHANNELS = 4, 64 * 1024, 16


# ------------------------------------------------------------------------------------------------
# The seed file


def write_seed_file(path: str | os.PathLike, seeds: torch.Tensor) -> None:
    """Write ``seeds`` (int64 ``[H, W]`` or ``[K, H, W]``) as a seed file (module docstring):
    their low 32 bits, atomically."""
    if seeds.ndim == 2:
        seeds = seeds[None]
    size = check_shape(seeds, "K H W", "seeds")
    check_dtype(seeds, torch.int64, "seeds")
    words = (seeds.detach().cpu() & MASK32).numpy().astype("<u4")
    head = SEED_HEADER.pack(_MAGIC, _VERSION, size["W"], size["H"], size["K"], _UINT32)
    with atomic_write(Path(path)) as tmp:
        tmp.write_bytes(head + words.tobytes())


def read_seed_file(path: str | os.PathLike) -> torch.Tensor:
    """The seeds of a seed file as int64 ``[K, H, W]``. The header is checked against the file's
    size before the seeds are read: a header claiming more seeds than the file holds (or
    fewer) is refused without allocating them.

    Raises:
        FileFormatError: missing, no seed-file header, another version or dtype, or a size that
            disagrees with the header.
    """
    path = Path(path)
    try:
        file = path.open("rb")
    except OSError as err:
        raise FileFormatError(f"{path}: expected a seed file, got {err.strerror or err}") from None
    with file:
        head, size = file.read(SEED_HEADER.size), os.fstat(file.fileno()).st_size
        if len(head) < SEED_HEADER.size:
            raise FileFormatError(
                f"{path}: expected a {SEED_HEADER.size}-byte header, got {len(head)}"
            )
        magic, version, width, height, count, dtype = SEED_HEADER.unpack(head)
        if (magic, version, dtype) != (_MAGIC, _VERSION, _UINT32):
            raise FileFormatError(
                f"{path}: expected magic {_MAGIC!r}, version {_VERSION}, dtype {_UINT32} "
                f"(uint32), got {magic!r}, {version}, {dtype}"
            )
        want = SEED_HEADER.size + 4 * width * height * count
        if size != want:
            raise FileFormatError(
                f"{path}: expected {want} bytes for {count} x {height} x {width} seeds, got {size}"
            )
        data = file.read(want - SEED_HEADER.size + 1)
    if len(data) != want - SEED_HEADER.size:  # the file changed while it was read
        raise FileFormatError(f"{path}: expected {want} bytes, got {SEED_HEADER.size + len(data)}")
    words = np.frombuffer(data, dtype="<u4")
    return torch.from_numpy(words.astype(np.int64)).view(count, height, width)


# ------------------------------------------------------------------------------------------------
# The manifest


@dataclass(frozen=True)
class RendererManifest:
    """A checked renderer manifest (module docstring). ``path`` is the manifest file, or None
    for :func:`command_manifest`'s; ``folder`` is where the program runs; ``source`` the text
    that identifies it (the manifest's, or the template)."""

    path: Path | None
    folder: Path
    source: str
    name: str
    command: tuple[str, ...]
    buffers: tuple[str, ...]
    samplers: tuple[str, ...]
    dimensions: int
    timeout_s: float
    batch: bool
    description: str

    @property
    def label(self) -> str:
        """How messages name it: ``renderer 'native' (manifest.toml)``."""
        where = self.path.name if self.path is not None else "--renderer-cmd"
        return f"renderer {self.name!r} ({where})"


def _manifest(path: Path, folder: Path, source: str, doc: Document) -> RendererManifest:
    """The manifest of the checked document ``doc``, its command's placeholders and program
    checked too."""
    used = command_placeholders(path, doc.command, set(PLACEHOLDERS))
    need = [*_REQUIRED, *(("sampler", *_LDBN_PLACEHOLDERS) if "ldbn" in doc.samplers else ())]
    if len(doc.samplers) > 1 and "sampler" not in need:
        need.append("sampler")
    missing = [p for p in need if p not in used]
    if missing:
        raise ManifestError(
            f"{path}: command: expected the placeholder(s) {', '.join('{' + p + '}' for p in need)}"
            f" (samplers {', '.join(doc.samplers)}), got none for {', '.join(missing)}"
        )
    return RendererManifest(
        path=path if path.name != "--renderer-cmd" else None,
        folder=folder,
        source=source,
        **dict(doc, command=tuple(resolve_program(path, list(doc.command)))),
    )


def load_renderer_manifest(manifest_path: str | os.PathLike) -> RendererManifest:
    """Read and check a renderer manifest (module docstring).

    Raises:
        DtypeError: not a path. ManifestError: missing, malformed (with the line), an unknown
            key, a value of the wrong type, a missing placeholder, a program that is missing or
            escapes the manifest's folder.
    """
    if not isinstance(manifest_path, (str, os.PathLike)):
        raise DtypeError(
            f"manifest_path: expected a str or os.PathLike, got {type(manifest_path).__name__}"
        )
    path = Path(manifest_path).absolute()
    if not path.is_file():
        raise ManifestError(f"{path}: expected a renderer manifest file, got no such file")
    doc = read_manifest(path, Document, "renderer manifest")
    return _manifest(path, path.parent, path.read_text(encoding="utf-8"), doc)


#: Programs that run another one named after them (``python3 render.py``): the scene of a
#: ``--renderer-cmd`` is named after that one.
_INTERPRETER = re.compile(
    r"(\{python\}|python[0-9.]*|pypy[0-9.]*|env|sh|bash|zsh|dash|node|ruby|perl|julia|Rscript"
    r"|blender|uv|conda)(\.exe)?"
)


def _program_of(argv: list[str]) -> str:
    """The program a command line runs: its first word, or past an interpreter and its options
    (``python3 -u render.py``, ``{python} render.py``, ``env X=1 ./tracer``) the script's."""
    for i, word in enumerate(argv):
        if not _INTERPRETER.fullmatch(Path(word).name):
            return word
        rest = [w for w in argv[i + 1 :] if not w.startswith("-") and "=" not in w]
        if not rest:
            return word
        if not _INTERPRETER.fullmatch(Path(rest[0]).name):
            return rest[0]
    return argv[0]


def command_manifest(
    template: str, name: str | None = None, folder: str | os.PathLike | None = None
) -> RendererManifest:
    """The manifest of ``bnerr bench --renderer-cmd "TEMPLATE"``: ``template`` split with
    :func:`shlex.split` into argv (never run through a shell), run in ``folder`` (default: the
    current directory), named ``name`` (default: the program's file name without suffix, the
    script's after an interpreter and its options: ``{python}``, ``python3 -u``, ``bash``,
    ``env``...).
    It lists ``samplers = ["owen_sobol", "ldbn"]`` when the template has ``{sampler}`` and the
    four ``{ldbn_...}`` placeholders, else ``["owen_sobol"]``; the other keys keep their
    defaults (every Frame buffer the file holds is kept).

    Raises:
        DtypeError: ``template`` is not a string. ManifestError: as
            :func:`load_renderer_manifest`, or a template that ``shlex`` cannot split.
    """
    if not isinstance(template, str):
        raise DtypeError(f"template: expected a str, got {type(template).__name__}")
    where = Path(folder if folder is not None else Path.cwd()).absolute()
    pseudo = where / "--renderer-cmd"
    try:
        argv = shlex.split(template)
    except ValueError as err:
        raise ManifestError(
            f"--renderer-cmd {template!r}: expected a command line, got {err}"
        ) from None
    if not argv:
        raise ManifestError(f"--renderer-cmd: expected a command, got {template!r}")
    ldbn = all("{" + p + "}" in template for p in ("sampler", *_LDBN_PLACEHOLDERS))
    program = _program_of(argv)
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(program).stem) or "renderer"
    raw = dict(
        name=name if name is not None else (stem if stem[0].isalpha() else f"r{stem}"),
        command=argv,
        samplers=list(SAMPLERS if ldbn else SAMPLERS[:1]),
    )
    doc = validate(Document, raw, ManifestError, "", source=str(pseudo))
    return _manifest(pseudo, where, template, doc)


# ------------------------------------------------------------------------------------------------
# The sampler's placeholders


@functools.lru_cache(maxsize=8)
def _ldbn_sets(size: int) -> tuple[tuple[str, int, tuple], ...]:
    """The shipped LDBN key sets of tile ``size``: (exported name, frames, keys per frame)."""
    from bnerr.ldbn.keys import ldbn_file_name, load_ldbn_keys
    from bnerr.strategies.ldbn import LDBN_SETS

    sets = []
    for kind, frames, levels in dict.fromkeys(LDBN_SETS.values()):
        with contextlib.suppress(FileFormatError):  # a set not shipped at this size
            keys = load_ldbn_keys(kind, size, frames, levels)
            name = ldbn_file_name(kind, size, frames).removesuffix(".npy")
            sets.append((name, frames, tuple(keys)))
    return tuple(sets)


def _ldbn_values(sampler: object) -> dict[str, str]:
    """The ``{ldbn_...}`` values of an :class:`bnerr.sequences.LDBNSampler`: which exported key
    set and slice its keys are, and its offset."""
    keys = sampler.keys  # type: ignore[attr-defined]
    for name, frames, per_frame in _ldbn_sets(keys.size):
        for f, candidate in enumerate(per_frame):
            if candidate is keys or (
                torch.equal(candidate.scramble, keys.scramble)
                and torch.equal(candidate.rank, keys.rank)
                and candidate.seed0 == keys.seed0
            ):
                oy, ox = sampler.offset  # type: ignore[attr-defined]
                return dict(
                    ldbn_keys=name,
                    ldbn_slice=str(sampler.level * frames + f),  # type: ignore[attr-defined]
                    ldbn_offset_y=str(oy),
                    ldbn_offset_x=str(ox),
                )
    raise ValueRangeError(
        f"sampler {sampler!r}: expected the keys of a shipped LDBN key set (bnerr export "
        f"--ldbn), got keys of none"
    )


def sampler_values(manifest: RendererManifest, sampler: object) -> dict[str, str]:
    """The placeholders that describe ``sampler`` to the renderer (module docstring).

    Raises:
        ValueRangeError: a sampler the manifest does not list.
    """
    name = getattr(sampler, "name", "") or type(sampler).__name__
    if name not in manifest.samplers:
        raise ValueRangeError(
            f"{manifest.label}: expected a sampler it lists ({', '.join(manifest.samplers)}), "
            f"got {name!r}"
        )
    values = {"sampler": name, "ldbn_keys": "none"}
    values.update(dict.fromkeys(("ldbn_slice", "ldbn_offset_y", "ldbn_offset_x"), "0"))
    if name == "ldbn":
        values.update(_ldbn_values(sampler))
    return values


# ------------------------------------------------------------------------------------------------
# Running the renderer


def _fail(
    manifest: RendererManifest, argv: list[str], expected: str, got: str, work: Path
) -> ExternalProcessError:
    return program_error(manifest.label, argv, expected, got, log_tail(work))


def _read(
    manifest: RendererManifest, argv: list[str], path: Path, size: tuple[int, int], work: Path
) -> Frame:
    """The frame the program wrote at ``path``, checked (module docstring)."""
    if not path.is_file():
        raise _fail(manifest, argv, f"a frame EXR at {path.name}", "no such file", work)
    limit = _SIZE_FACTOR * size[0] * size[1] * _MAX_CHANNELS * 4 + _SIZE_SLACK
    if path.stat().st_size > limit:
        raise _fail(manifest, argv, f"at most {limit} bytes", f"{path.stat().st_size}", work)
    try:
        frame = read_frame(path)
    except FileFormatError as err:
        raise _fail(manifest, argv, "an OpenEXR frame", str(err), work) from None
    if (frame.height, frame.width) != size:
        got = f"{frame.width} x {frame.height}"  # width x height, as --res and bnerr eval say
        want = f"a frame of {size[1]} x {size[0]} pixels (width x height)"
        raise _fail(manifest, argv, want, got, work)
    missing = [b for b in manifest.buffers if getattr(frame, b) is None]
    if missing:
        raise _fail(
            manifest,
            argv,
            f"the buffers {', '.join(manifest.buffers)}",
            "no " + ", ".join(missing),
            work,
        )
    for name in FRAME_BUFFERS:
        value = getattr(frame, name)
        if value is not None:
            try:
                check_finite(value, name)
            except ValueError as err:  # "<name>: expected finite values, got ..."
                got = str(err).partition("got ")[2]
                raise _fail(manifest, argv, f"finite values in {name}", got, work) from None
    return frame


class ExternalRenderer:
    """A renderer program behind the render callback (module docstring).

    Args:
        manifest: a :class:`RendererManifest` (:func:`load_renderer_manifest`,
            :func:`command_manifest`).

    Attributes:
        manifest: that manifest; ``name`` and ``dimensions`` are its.
    """

    def __init__(self, manifest: RendererManifest) -> None:
        if not isinstance(manifest, RendererManifest):
            raise DtypeError(
                f"manifest: expected a RendererManifest, got {type(manifest).__name__}"
            )
        self.manifest = manifest
        self.name, self.dimensions = manifest.name, manifest.dimensions

    def fingerprint(self) -> str:
        """A hash of the manifest (or template) and of the program's file, if it names one: it
        changes whenever the renderer's frames could (the reference cache's key)."""
        digest = hashlib.sha256(self.manifest.source.encode())
        for arg in self.manifest.command[:2]:
            if os.path.isabs(arg) and os.path.isfile(arg):
                digest.update(Path(arg).read_bytes())
        return digest.hexdigest()[:16]

    def render(self, t: int, seeds: torch.Tensor, sampler: object, spp: int) -> Frame:
        """Frame ``t`` of ``seeds [H, W]`` int64 with ``sampler`` at ``spp`` samples per pixel:
        one run of the program."""
        check_shape(seeds, "H W", "seeds")
        return self.render_batch(t, seeds[None], sampler, spp)[0]

    def render_batch(self, t: int, seeds: torch.Tensor, sampler: object, spp: int) -> list[Frame]:
        """The frames of ``seeds [K, H, W]``: K runs, or one with ``batch``; each the frame
        :meth:`render` gives for ``seeds[k]``, on the seeds' device."""
        check_shape(seeds, "K H W", "seeds")
        check_dtype(seeds, torch.int64, "seeds")
        values = dict(
            sampler_values(self.manifest, sampler),
            spp=str(check_positive_int(spp, "spp")),
            frame=str(check_positive_int(t, "t", minimum=0)),
            height=str(seeds.shape[1]),
            width=str(seeds.shape[2]),
            python=sys.executable,
        )
        groups = [seeds] if self.manifest.batch else [s[None] for s in seeds]
        frames = [f for group in groups for f in self._run(group, values)]
        return [_on(f, seeds.device) for f in frames]

    def _run(self, seeds: torch.Tensor, values: Mapping[str, str]) -> list[Frame]:
        """One run of the program on the seed images ``seeds [K, H, W]``."""
        work = Path(tempfile.mkdtemp(prefix=f"bnerr-{self.name}-"))
        try:
            out = work / ("out" if self.manifest.batch else "out.exr")
            if self.manifest.batch:
                out.mkdir()
            write_seed_file(work / "seeds.bin", seeds)
            argv = [
                a.format(**values, seeds=str(work / "seeds.bin"), out=str(out))
                for a in self.manifest.command
            ]
            ms = run_program(
                self.manifest.label,
                argv,
                cwd=self.manifest.folder,
                timeout_s=self.manifest.timeout_s,
                work=work,
            )
            paths = [out / f"{k}.exr" for k in range(len(seeds))] if self.manifest.batch else [out]
            size = (seeds.shape[1], seeds.shape[2])
            frames = [_read(self.manifest, argv, p, size, work) for p in paths]
            for frame in frames:
                frame.timings = {"render": ms / len(frames)}
            return frames
        finally:
            shutil.rmtree(work, ignore_errors=True)

    def __repr__(self) -> str:
        return f"ExternalRenderer({self.manifest.label})"


def _on(frame: Frame, device: torch.device) -> Frame:
    if device.type == "cpu":
        return frame
    moved = {n: getattr(frame, n) for n in FRAME_BUFFERS if getattr(frame, n) is not None}
    return Frame(**{n: v.to(device) for n, v in moved.items()}, timings=frame.timings)
