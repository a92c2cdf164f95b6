"""High-spp references: rendered once, cached as EXR files keyed by everything they depend on.

A reference is rendered with Owen-scrambled Sobol (``Parts.reference_sampler``) and seeds that no
strategy uses (:func:`reference_seeds`), once per scene, motion/depth condition, frame,
resolution, spp and code version, and cached under ``cache/references/``. The **cache key** (the
file name, :meth:`ReferenceCache.path`) holds every input of the render:

- scene name, motion and depth condition and the frame the renderer sees (static scenes, motion 0,
  share one reference across frames); a plug-in scene's name carries its fingerprint too
  (:attr:`bnerr.plugins.Plugin.fingerprint`: a scene file's hash, a distribution's version), so
  that a scene edited under the same name never reuses the references of its former self;
- resolution and spp;
- the reference sampler's name and the seed salt (the seed image of frame t is a fixed function of
  the salt and t), plus :data:`REFERENCE_FORMAT`, bumped by hand when the seed scheme or the file
  layout changes;
- the code version (``Parts.code_version``, :func:`benchmarks.sweep.version.code_version`): a hash
  of the source files a reference's pixels depend on (every ``.py`` of ``renderers``, of the
  ``bnerr.sequences`` module and ``bnerr/hashing.py``). A change to the tracer or to a sampler
  never reuses a stale reference;
- for a plug-in scene, its content (``Parts.scene_version``): a scene file's hash, or for a
  Mitsuba XML scene Mitsuba's version and the hash of the XML and its camera path, whose
  references Mitsuba renders (the scene renders itself, :func:`benchmarks.sweep.parts.render_any`);
- the device type, for a sweep off the CPU (``Parts.device``, ``bnerr bench --device cuda``: a
  ``_cuda`` before ``.exr``): the tracer's float rounding differs between devices, so a CUDA
  reference is not the CPU one bit for bit, and a CPU sweep never reads it (the CPU's names are
  unchanged, so its cached references stay valid).

**Device.** A reference is rendered on ``Parts.device`` (the parts' render moves its seeds there)
and one read from the cache is moved there, so the frames it judges and it sit on one device.

**Compiled references.** A reference is rendered with ``compile=True`` exactly when it traces at
least ``2^22`` paths (``H * W * spp >= REFERENCE_COMPILE_PATHS``; :func:`reference_compile`), and
eagerly otherwise, whatever ``BNERR_COMPILE`` says. This is the tracer's former automatic rule
(``compile=None`` compiled renders from 2^22 paths before compiling became opt-in): the committed
results in ``results/`` were measured against references rendered under it (128x128 at 512 and
1024 spp: compiled), and a compiled render differs from an eager one in the last bits, so keeping
the rule keeps the references bit-identical to those and the committed results valid. The rule
is part of the cache key through :data:`REFERENCE_FORMAT`.

The reference's own noise adds its variance to every strategy's MSE alike; the records keep it
(``Record.reference.floor``) so that a reader can see when it matters.

Not for: the cross-check's Mitsuba references of the built-in scenes (:mod:`renderers.mitsuba`
has its own).
"""

from __future__ import annotations

import errno
import warnings
from collections.abc import Callable
from pathlib import Path

import torch

from benchmarks.sweep.parts import Parts, Scene
from benchmarks.sweep.plan import Run
from bnerr.errors import BnerrError, FileFormatError
from bnerr.frame import Frame
from bnerr.hashing import MASK32, mix32_45d9f3b
from bnerr.io import read_frame, write_frame
from bnerr.outputs import clean_stale_temporaries

__all__ = [
    "REFERENCE_COMPILE_PATHS",
    "REFERENCE_FORMAT",
    "ReferenceCache",
    "reference_compile",
    "reference_seeds",
]

#: Bumped by hand when the reference seeds' scheme, the compile rule (:func:`reference_compile`) or
#: the cache's file layout changes.
REFERENCE_FORMAT = "r3"
#: References of at least this many paths (``H * W * spp``) are rendered with ``compile=True``.
REFERENCE_COMPILE_PATHS = 1 << 22
_REFERENCE_SALT = 0x5EED_BA5E  # keeps reference seeds apart from every strategy's seeds
_REFERENCES_IN_MEMORY = 16  # a run revisits its measured frames once per seed set


def reference_seeds(height: int, width: int, t: int) -> torch.Tensor:
    """Distinct-looking seeds ``[H, W]`` int64 in [0, 2^32) for the reference of frame ``t``.

    ``mix32(mix32(index ^ salt) ^ t)`` with the ``0x45d9f3b`` mix
    (:func:`bnerr.hashing.mix32_45d9f3b`), keyed by a salt that no strategy uses, so that a
    reference never shares a sequence with the frame it judges (a shared sequence would correlate
    their errors and understate the MSE).
    """
    index = torch.arange(height * width, dtype=torch.int64)
    seeds = mix32_45d9f3b(mix32_45d9f3b(index ^ _REFERENCE_SALT) ^ (t & MASK32))
    return seeds.reshape(height, width)


def reference_compile(height: int, width: int, spp: int) -> bool:
    """Whether a reference of ``height x width`` at ``spp`` is rendered with ``torch.compile``.

    True exactly when ``height * width * spp >= 2^22`` (:data:`REFERENCE_COMPILE_PATHS`): the
    tracer's former automatic rule, under which the committed results' references were rendered
    (see the module docstring). The environment's ``BNERR_COMPILE`` does not enter.
    """
    return height * width * spp >= REFERENCE_COMPILE_PATHS


#: The errors of a cache folder that refuses writes (read-only, full, not ours): the sweep goes
#: on with its references in memory. Any other (``--cache`` names a file) is raised.
_REFUSALS = frozenset({errno.EROFS, errno.EACCES, errno.EPERM, errno.ENOSPC, errno.EDQUOT})


def _errno(err: OSError) -> int | None:
    """``err``'s errno, or that of the OSError it was raised from (atomic_write's one-liners)."""
    cause = err.__cause__
    return err.errno if err.errno is not None else getattr(cause, "errno", None)


def _device_suffix(device: str) -> str:
    """What the cache key adds for a sweep on ``device``: nothing on the CPU, ``_cuda`` on any
    CUDA device (the index is where it ran, not what it computed; two GPU models may still round
    apart in the last bits, as two CPUs' vector units may: the cache trusts the folder's owner)."""
    kind = torch.device(device).type
    return "" if kind == "cpu" else f"_{kind}"


class ReferenceCache:
    """High-spp references, rendered on first use and kept as EXR files (and the last few in
    memory).

    Args:
        root: cache folder (``cache/references`` by default in the CLI; git-ignored), or None to
            keep references in memory only. A folder that refuses writes (read-only, a full
            disk, permissions) is still read; the references it lacks are rendered and kept in
            memory, with one warning (on a Ray node they travel through the object store).
        parts: the parts that render; ``parts.code_version`` enters every key.
    """

    def __init__(self, root: str | Path | None, parts: Parts) -> None:
        self.root = Path(root) if root is not None else None
        self.parts = parts
        self._memory: dict[str, Frame] = {}
        self.unwritable: str | None = None  # why the cache folder refused a write, if it did
        self._cleaned: set[Path] = set()
        #: Told what is being rendered before each reference render, and "" after it (the
        #: progress bar's text: references render before a run's first frame, for a minute on
        #: a fresh machine).
        self.on_render: Callable[[str], None] | None = None
        self._compiled = False

    def _store(self, path: Path, frame: Frame) -> None:
        """Write ``frame`` to the cache file ``path`` (atomically). A folder that refuses (read
        only, a full disk) is said once, in a warning, and not tried again: the sweep goes on
        with its references in memory, which measures the same cells (only a later sweep renders
        them again)."""
        if self.root is None or self.unwritable is not None:
            return
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            if path.parent not in self._cleaned:  # what writers killed mid-write left
                clean_stale_temporaries(path.parent)
                self._cleaned.add(path.parent)
            write_frame(path, frame)
        except OSError as err:  # OutputPathError among them: atomic_write left no partial file
            if _errno(err) not in _REFUSALS:  # a file where the folder should be: the user's
                raise
            plain = f"{err.filename or path}: {err.strerror or err}"  # mkdir's, without [Errno]
            self.unwritable = str(err) if isinstance(err, BnerrError) else plain
            warnings.warn(
                f"--cache {self.root}: expected a writable reference cache, got "
                f"{self.unwritable}; references are kept in memory for this run only",
                stacklevel=3,
            )

    def path(self, run: Run, t_render: int) -> Path:
        """The cache file of ``run``'s reference at renderer frame ``t_render``."""
        depth = "d" if run.depth is None else f"d{run.depth}"
        sampler = self.parts.reference_sampler()
        sampler_name = getattr(sampler, "name", "") or type(sampler).__name__
        version = self.parts.code_version.replace("/", "_")
        content = self.parts.scene_version(run.scene)
        if content:  # a plug-in scene: its files' hash (a Mitsuba scene: and Mitsuba's version)
            version += "_" + content.replace("/", "_").replace(":", "-")
        name = (
            f"{run.scene}_m{run.motion}_{depth}_t{t_render}_{run.width}x{run.height}"
            f"_spp{run.reference_spp}_{sampler_name}_s{_REFERENCE_SALT:08x}"
            f"_{REFERENCE_FORMAT}_{version}{_device_suffix(self.parts.device)}.exr"
        )
        return (self.root if self.root is not None else Path()) / run.scene / name

    def _tell(self, run: Run, t_render: int, compile: bool) -> None:
        if self.on_render is None:
            return
        first = compile and not self._compiled  # the process's first compiled render warms up
        self._compiled = self._compiled or compile
        warm = ", compiling the tracer first (up to a minute)" if first else ""
        self.on_render(f"reference t={t_render} at {run.reference_spp} spp{warm}")

    def get(self, run: Run, scene: Scene, t_render: int) -> Frame:
        """The reference Frame of ``scene`` at renderer frame ``t_render`` for ``run``'s settings.

        A torn or corrupt cache file is rendered again, not trusted.
        """
        path = self.path(run, t_render)
        key = str(path)
        if key in self._memory:
            return self._memory[key]
        frame = None
        if self.root is not None and path.exists():
            try:
                frame = read_frame(path)
            except FileFormatError:
                frame = None
            if frame is not None and _device_suffix(self.parts.device):
                frame = frame.to(self.parts.device)
        if frame is None:
            seeds = reference_seeds(run.height, run.width, t_render)
            sampler = self.parts.reference_sampler()
            spp = run.reference_spp
            compile = reference_compile(run.height, run.width, spp)
            self._tell(run, t_render, compile)
            frame = self.parts.render(scene, t_render, seeds, sampler, spp, compile=compile)
            if self.on_render is not None:
                self.on_render("")  # done: back to the caller's own text
            self._store(path, frame)
        if len(self._memory) >= _REFERENCES_IN_MEMORY:
            self._memory.pop(next(iter(self._memory)))
        self._memory[key] = frame
        return frame
