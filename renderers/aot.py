"""The tracer's vertex stage compiled ahead of time, cached on disk, loaded in milliseconds.

``torch.compile`` costs every new process its warm-up even when inductor's on-disk caches hit:
importing dynamo and inductor (about 5 s here), tracing :func:`renderers.integrator.vertex_step`
again and checking its guards. Measured on the 2-core machine, a ``bnerr render --scene cornell
--res 256x256 --spp 32`` process spent 6.5 s of warm-up before a 1.1 s render, slower than its
4.5 s eager render. An AOTInductor package (``torch.export`` of the stage, then
``torch._inductor.aoti_compile_and_package``) holds the same fused C++ kernels in a shared library
that ``torch._C._aoti.AOTIModelPackageLoader`` opens without importing dynamo or inductor: about
10 ms, after which the render runs at the compiled speed.

- **One package per scene layout**, the lane count dynamic: the static layout of
  :class:`~renderers.geometry.SceneTensors` (object ids, textures, lights, whether there is a
  medium) is baked into the graph; its tensors (which move from frame to frame) and the lanes'
  state are the package's inputs. Building one takes about a minute (export, then a C++ build).
- **Key.** The file name hashes the torch version, the host CPU (:func:`bnerr.native.build.
  cpu_identity`: the kernels are built for it), the layout and the sources of the stage's modules
  (:mod:`renderers.integrator`, :mod:`renderers.tracer`, :mod:`renderers.geometry`): an edit or
  an upgrade builds a new one.
- **Where.** ``$BNERR_CACHE_DIR/aot`` (default ``~/.cache/bnerr/aot``), a private folder
  (:func:`bnerr.native.build.secure_dir`); a package is written under a temporary name and renamed,
  so a reader never sees half of one, and two builders of the same key both succeed.
- **Bits.** A packaged render is bit-identical between runs and processes. It holds inductor's
  kernels for the same graph, so it matched ``torch.compile``'s render bit for bit where
  measured (cornell, 256x256, 32 spp); like it, it may differ from the eager render in the last
  bits (the fused kernels round differently). :func:`renderers.render` keeps ``compile=True``
  for ``torch.compile`` (the benchmark's references) and takes ``compile=stage`` for this one.

``python -m renderers.aot SCENE [SCENE ...]`` builds the packages of the named scenes' layouts
(what ``bnerr render`` starts in the background, niced, after an eager render that would have
run compiled had a package been there).
"""

from __future__ import annotations

import ctypes
import dataclasses
import hashlib
import os
import subprocess
import sys
import tempfile
import warnings
import zipfile
from pathlib import Path

import torch

from bnerr.native.build import cache_dir, cpu_identity, open_library_bytes, secure_dir
from renderers.catalog import get_scene
from renderers.geometry import SceneTensors, scene_tensors
from renderers.integrator import PathVertex, vertex_step
from renderers.layout import Layout

__all__ = [
    "AotStep",
    "build",
    "has_package",
    "load",
    "package_path",
    "stage",
    "start_background_build",
]

#: Bumped when the package's calling convention changes.
_FORMAT = "1"
#: Sources whose code the stage runs (an edit to any of them changes the key).
_SOURCES = ("aot.py", "integrator.py", "tracer.py", "geometry.py")


def _split(st: SceneTensors) -> tuple[list[str], dict[str, object]]:
    """The names of ``st``'s tensor fields (the package's first inputs, in this order) and its
    other fields (the static layout baked into the package; absent tensors are None here)."""
    tensors, static = [], {}
    for field in dataclasses.fields(st):
        value = getattr(st, field.name)
        if isinstance(value, torch.Tensor):
            tensors.append(field.name)
        else:
            static[field.name] = value
    return tensors, static


def _key(st: SceneTensors) -> str:
    names, static = _split(st)
    shapes = [(n, tuple(getattr(st, n).shape), str(getattr(st, n).dtype)) for n in names]
    here = Path(__file__).parent
    parts = [_FORMAT, torch.__version__, cpu_identity(), repr(sorted(static.items())), repr(shapes)]
    parts += [(here / name).read_text() for name in _SOURCES]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:20]


def package_path(st: SceneTensors) -> Path:
    """Where the package of ``st``'s layout lives (whether or not it is built)."""
    return cache_dir().parent / "aot" / f"vertex_{_key(st)}.pt2"


def has_package(scene_name: str, static: bool = False) -> bool:
    """Whether the package of the named scene's layout is built (its frame 0's tensors: every
    frame of a scene has the same layout and shapes)."""
    scene = get_scene(scene_name, animated=not static)
    return package_path(scene_tensors(scene, 0, torch.device("cpu"))).is_file()


class _Stage(torch.nn.Module):
    """:func:`~renderers.integrator.vertex_step` over flat tensors, the layout fixed (export)."""

    def __init__(self, st: SceneTensors, has_distance: bool, has_choice: bool) -> None:
        super().__init__()
        self.names, self.static = _split(st)
        self.has_distance, self.has_choice = has_distance, has_choice

    def forward(self, *inputs: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        k = len(self.names)
        st = SceneTensors(**dict(zip(self.names, inputs[:k])), **self.static)  # type: ignore[arg-type]
        rest = list(inputs[k:])
        o, d, beta, radiance, alive, prev_pdf = rest[:6]
        u_distance = rest.pop(6) if self.has_distance else None
        u_choice = rest.pop(6) if self.has_choice else None
        u_light, u_direction, first, last = rest[6:]
        ends = (first, last)
        args = (u_distance, u_choice, u_light, u_direction, ends)
        # A plain tuple out: the package's outputs are the eight tensors, AotStep names them.
        return tuple(vertex_step(st, o, d, beta, radiance, alive, prev_pdf, *args))


def _flat(st: SceneTensors, names: list[str], args: tuple) -> list[torch.Tensor]:
    """The package's inputs: ``st``'s tensors, then the stage's (None rows left out, the rest
    contiguous, the flags ``ends`` last)."""
    *lanes, ends = args
    flat = [getattr(st, n) for n in names]
    flat += [a.contiguous() for a in lanes if a is not None]
    return flat + list(ends)


def _capsule_api() -> ctypes.PyDLL:
    api = ctypes.pythonapi
    api.PyCapsule_GetPointer.restype = ctypes.c_void_p
    api.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
    api.PyCapsule_New.restype = ctypes.py_object
    api.PyCapsule_New.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_void_p]
    return api


def _open_library(path: Path) -> ctypes.CDLL:
    """The package's model library, copied out of the archive into a private file, opened and
    unlinked (the loader keeps its mapping)."""
    with zipfile.ZipFile(path) as archive:
        (name,) = [n for n in archive.namelist() if n.endswith(".so")]
        data = archive.read(name)
    return open_library_bytes(data, None, "bnerr_aot_")


class AotStep:
    """A loaded package, called like :func:`~renderers.integrator.vertex_step` with ``ends`` (the
    uniform convention of :func:`renderers.integrator.trace`), safe to call from several threads.

    The model library is called through ctypes, which lets go of the GIL while its kernels run
    (``AOTIModelPackageLoader.run`` holds it: measured, a second Python thread ran at a tenth of
    its speed during the calls), so :func:`renderers.render`'s worker threads trace their chunks
    at once, as with ``torch.compile``. Inputs and outputs cross as ATen tensor handles
    (``torch._C._aoti``), the way inductor's own C++ wrapper calls such a library.
    """

    uniform = True

    def __init__(self, path: Path, names: list[str], runners: int) -> None:
        self._lib = _open_library(path)
        self._api = _capsule_api()
        self._handle = ctypes.c_void_p()
        made = self._lib.AOTInductorModelContainerCreateWithDevice(
            ctypes.byref(self._handle), ctypes.c_size_t(max(1, runners)), b"cpu", None
        )
        count, constants = ctypes.c_size_t(), ctypes.c_size_t()
        self._lib.AOTInductorModelContainerGetNumOutputs(self._handle, ctypes.byref(count))
        self._lib.AOTInductorModelContainerGetNumConstants(self._handle, ctypes.byref(constants))
        if made != 0 or constants.value != 0:  # the stage has no weights: nothing to load
            raise RuntimeError(f"the model library would not start (code {made})")
        self._outputs = count.value
        self._names = names

    def __call__(self, st: SceneTensors, *args: object) -> PathVertex:
        inputs = torch._C._aoti.unsafe_alloc_void_ptrs_from_tensors(_flat(st, self._names, args))
        handles = (ctypes.c_void_p * len(inputs))(
            *[self._api.PyCapsule_GetPointer(c, None) for c in inputs]
        )  # the library takes these handles over (and frees them)
        out = (ctypes.c_void_p * self._outputs)()
        n_in, n_out = ctypes.c_size_t(len(inputs)), ctypes.c_size_t(self._outputs)
        code = self._lib.AOTInductorModelContainerRun(
            self._handle, handles, n_in, out, n_out, None, None
        )
        if code != 0:
            raise RuntimeError(f"the compiled stage failed (code {code})")
        capsules = [self._api.PyCapsule_New(h, None, None) for h in out]
        return PathVertex(*torch._C._aoti.alloc_tensors_by_stealing_from_void_ptrs(capsules))

    def __del__(self) -> None:
        if getattr(self, "_handle", None) and self._handle.value:
            self._lib.AOTInductorModelContainerDelete(self._handle)


def load(st: SceneTensors, runners: int = 1) -> AotStep | None:
    """The built package of ``st``'s layout, or None when there is none (or it will not load)."""
    path = package_path(st)
    if secure_dir(path.parent) is not None or not path.is_file():
        return None
    try:
        return AotStep(path, _split(st)[0], runners)
    except (OSError, ValueError, RuntimeError, zipfile.BadZipFile) as err:  # damaged, foreign
        warnings.warn(f"renderers: ignoring {path} ({err})", RuntimeWarning, stacklevel=2)
        return None


def _example(st: SceneTensors, layout: Layout, lanes: int) -> tuple[torch.Tensor, ...]:
    """Inputs of the right kinds for exporting the stage of ``st`` with ``layout``: each its own
    tensor (export treats inputs that alias as one)."""
    names, _ = _split(st)
    vecs = [torch.full((3, lanes), v) for v in (0.0, 0.5, 1.0, 0.0)]  # o, d, beta, radiance
    rows = [torch.full((lanes,), 0.5) for _ in range(3)]
    has = (layout.distance(0) is not None, layout.light_choice(0) is not None)
    u = [rows[i + 1] for i, h in enumerate(has) if h]
    pairs = [torch.full((2, lanes), 0.5) for _ in range(2)]
    flags = [torch.tensor(True), torch.tensor(False)]
    alive = torch.ones(lanes, dtype=torch.bool)
    st_inputs = [getattr(st, n) for n in names]
    return tuple(st_inputs + vecs + [alive, rows[0]] + u + pairs + flags)


def build(st: SceneTensors, layout: Layout) -> Path:
    """Export and compile the package of ``st``'s layout into the cache (about a minute)."""
    import torch._inductor  # imported only to build: loading needs neither dynamo nor inductor

    path = package_path(st)
    reason = secure_dir(path.parent)
    if reason is not None:
        raise OSError(reason)
    has = (layout.distance(0) is not None, layout.light_choice(0) is not None)
    example = _example(st, layout, 1024)
    lanes = torch.export.Dim("lanes", min=2, max=1 << 28)
    k = len(_split(st)[0])
    dims = [None] * k + [{1: lanes}] * 4 + [{0: lanes}] * 2 + [{0: lanes}] * sum(has)
    dims += [{1: lanes}] * 2 + [None, None]
    program = torch.export.export(
        _Stage(st, *has), example, dynamic_shapes=(tuple(dims),), strict=False
    )
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".pt2")
    os.close(fd)
    try:
        torch._inductor.aoti_compile_and_package(program, package_path=tmp)
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)
    return path


def start_background_build(scene_name: str, static: bool) -> None:
    """Build ``scene_name``'s package in a detached, niced process (this one does not wait)."""
    cmd = [sys.executable, "-m", "renderers.aot", scene_name] + (["--static"] if static else [])
    nice = ["nice", "-n", "19"] if os.name == "posix" else []
    subprocess.Popen(
        nice + cmd,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )


def main(argv: list[str]) -> int:
    """Build the packages of the scenes named in ``argv`` (``--static``: their static variants)."""
    static = "--static" in argv
    for name in (a for a in argv if a != "--static"):
        scene = get_scene(name, animated=not static)
        st = scene_tensors(scene, 0, torch.device("cpu"))
        if not package_path(st).is_file():
            print(build(st, scene.layout))
    return 0


def stage(st: SceneTensors, layout: Layout, workers: int) -> AotStep | None:
    """The packaged stage of ``st``'s layout for ``workers`` threads: loaded, else built now
    (about a minute) and loaded; None, with a warning, when building fails (the caller traces
    eagerly). What :func:`renderers.render` runs with ``compile="aot"``."""
    step = load(st, workers)
    if step is not None:
        return step
    try:
        build(st, layout)
    except Exception as err:  # export, inductor, the C++ toolchain, the cache folder
        warnings.warn(
            f"renderers: building the compiled stage failed, tracing in eager mode "
            f"({type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''})",
            RuntimeWarning,
            stacklevel=2,
        )
        return None
    return load(st, workers)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
