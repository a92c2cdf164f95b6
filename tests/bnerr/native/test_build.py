"""Tests for bnerr.native: a leaf package; its build, cache and loader (only a library this package
built is loaded; every failure is one warning, then the torch path); and the disable switch.

Most tests build with a fake compiler (``$CC`` set to a small script) into a temporary
``$BNERR_CACHE_DIR``: a stub library with the two entry points compiles in a fraction of a
second, where the real kernels take several. The real kernels are exercised by the permute and
retarget tests.
"""

import ast
import hashlib
import json
import os
import shutil
import stat
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import torch

from bnerr import native
from bnerr.color import LUMINANCE_WEIGHTS
from bnerr.errors import ValueRangeError
from bnerr.native import build as native_build
from bnerr.permutation.permute import luminance, plan_sort, sort_pass, sort_pass_reference
from bnerr.permutation.retarget import inverse_field, optimize_retarget, retarget_sources

needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")

# A library with both entry points; returning 1 ("bad sizes") makes every caller fall back.
_STUB = "int bnerr_sort_pass(void) { return 1; }\nint bnerr_retarget(void) { return 1; }\n"
_UNRELATED = "int something_else(void) { return 0; }\n"


@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """A private cache folder and a loader that has not looked yet (and forgets again after)."""
    monkeypatch.setenv("BNERR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("BNERR_NATIVE", raising=False)
    native.reset()
    yield tmp_path
    native.reset()


def _script(path: Path, body: str) -> Path:
    path.write_text(f"#!{sys.executable}\n{body}")
    path.chmod(0o755)
    return path


def _fake_cc(tmp_path: Path, source: str, name: str = "fake-cc") -> Path:
    """A compiler that builds ``source`` instead of the C file it is given (and logs each call)."""
    stub = tmp_path / f"{name}.c"
    stub.write_text(source)
    body = (
        "import subprocess, sys\n"
        f"open({str(tmp_path / (name + '.log'))!r}, 'a').write('call\\n')\n"
        f"args = [{str(stub)!r} if a.endswith('.c') else a for a in sys.argv[1:]]\n"
        "sys.exit(subprocess.call(['cc', *args]))\n"
    )
    return _script(tmp_path / name, body)


def _load(times: int = 2) -> tuple[native.Kernels | None, list[str]]:
    """Load (several times) and return the kernels and the RuntimeWarnings' messages."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(times):
            kernels = native.load()
    return kernels, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


def _torch_path_still_right() -> None:
    gen = torch.Generator().manual_seed(0)
    seeds = torch.randperm(9 * 11, generator=gen).view(9, 11)
    color, mask = torch.rand(3, 9, 11, generator=gen), torch.rand(9, 11, generator=gen)
    assert torch.equal(sort_pass(seeds, color, mask, 4), sort_pass_reference(seeds, color, mask, 4))


def _record(tmp_path: Path) -> tuple[Path, dict]:
    folder = tmp_path / "cache" / "native"
    (sidecar,) = folder.glob("permute_*.json")
    record = json.loads(sidecar.read_text())
    return folder / record["library"], record


def test_native_package_is_a_leaf():
    # It imports nothing from bnerr but its errors (and itself): no import circle through it.
    folder = Path(native.__file__).parent
    imported = set()
    for file in folder.glob("*.py"):
        for node in ast.walk(ast.parse(file.read_text())):
            if isinstance(node, ast.Import):
                imported |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module:
                imported.add(node.module)
    ours = {name for name in imported if name.split(".")[0] == "bnerr"}
    assert ours <= {"bnerr.errors", "bnerr.native"}, ours
    # The library ships only its own kernel; the denoisers' live in denoisers/native.
    assert sorted(path.name for path in folder.glob("*.c")) == ["permute.c"]


def test_disabled_by_environment_is_silent(fresh, monkeypatch):
    monkeypatch.setenv("BNERR_NATIVE", "0")
    kernels, messages = _load()
    assert kernels is None and messages == []
    assert native.status() == "disabled by BNERR_NATIVE=0" and not native.available()
    _torch_path_still_right()


def test_missing_compiler_gives_one_warning(fresh, monkeypatch):
    monkeypatch.setenv("CC", str(fresh / "no-such-compiler"))
    kernels, messages = _load()
    assert kernels is None and len(messages) == 1
    assert "no-such-compiler" in messages[0] and "was not found" in messages[0]
    assert "the torch path is used" in messages[0] and "slower" in messages[0]
    assert "was not found" in native.status()
    _torch_path_still_right()


def test_failing_compiler_gives_one_warning_quoting_its_error(fresh, monkeypatch):
    body = (
        "import sys\n"
        "sys.stderr.write('In file permute.c:\\npermute.c:3:1: error: planted failure\\n"
        "permute.c:9:2: error: second planted failure\\n')\n"
        "sys.exit(1)\n"
    )
    compiler = _script(fresh / "broken-cc", body)
    monkeypatch.setenv("CC", str(compiler))
    kernels, messages = _load()
    assert kernels is None and len(messages) == 1  # both flag sets failed: still one warning
    assert str(compiler) in messages[0]
    assert "error: planted failure | permute.c:9:2: error: second planted failure" in messages[0]
    assert "the torch path is used" in messages[0]
    assert "planted failure" in native.status()
    assert "In file permute.c" in native.compiler_output()  # the full stderr is kept
    _torch_path_still_right()


@needs_cc
def test_build_records_the_hash_in_a_private_cache_and_reuses_it(fresh, monkeypatch):
    monkeypatch.setenv("CC", str(_fake_cc(fresh, _STUB)))
    kernels, messages = _load()
    assert kernels is not None and messages == []
    assert native.status().startswith("built at ")
    folder = fresh / "cache" / "native"
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    library, record = _record(fresh)
    assert hashlib.sha256(library.read_bytes()).hexdigest() == record["sha256"]
    assert record["sha256"][:16] in library.name
    native.reset()
    kernels, messages = _load()
    assert kernels is not None and messages == []
    assert native.status().startswith("cached at ")
    assert (fresh / "fake-cc.log").read_text().count("call") == 1  # built once


@needs_cc
def test_planted_library_is_rebuilt_never_loaded(fresh, monkeypatch):
    monkeypatch.setenv("CC", str(_fake_cc(fresh, _STUB)))
    assert native.load() is not None
    library, record = _record(fresh)
    marker = fresh / "planted-ran"
    planted_c = fresh / "planted.c"
    planted_c.write_text(
        "#include <stdio.h>\n"
        "__attribute__((constructor)) static void planted(void) {\n"
        f'    FILE *f = fopen("{marker}", "w"); if (f) fclose(f);\n'
        "}\n" + _STUB
    )
    planted = fresh / "planted.so"
    subprocess.run(["cc", "-shared", "-fPIC", str(planted_c), "-o", str(planted)], check=True)
    for plant in ("copy", "link"):
        library.unlink()
        if plant == "copy":
            shutil.copyfile(planted, library)
        else:
            library.symlink_to(planted)
        native.reset()
        kernels, messages = _load()
        assert not marker.exists(), f"a planted library ({plant}) was loaded"
        assert kernels is not None and native.status().startswith("built at ")
        assert len(messages) == 1 and "hash mismatch" in messages[0]
        assert not library.is_symlink()
        assert hashlib.sha256(library.read_bytes()).hexdigest() == record["sha256"]


@needs_cc
def test_sidecar_naming_another_file_is_ignored(fresh, monkeypatch):
    monkeypatch.setenv("CC", str(_fake_cc(fresh, _STUB)))
    assert native.load() is not None
    library, record = _record(fresh)
    sidecar = library.parent / (library.name.rsplit("_", 1)[0] + ".json")
    record["library"] = "../../elsewhere.so"
    sidecar.write_text(json.dumps(record))
    native.reset()
    kernels, messages = _load()
    assert kernels is not None and messages == [] and native.status().startswith("built at ")
    assert json.loads(sidecar.read_text())["library"] == library.name


@needs_cc
def test_library_without_the_functions_falls_back_with_a_warning(fresh, monkeypatch):
    monkeypatch.setenv("CC", str(_fake_cc(fresh, _UNRELATED)))
    kernels, messages = _load()
    assert kernels is None and len(messages) == 1
    assert "lacks the functions bnerr_sort_pass, bnerr_retarget" in messages[0]
    assert "the torch path is used" in messages[0]
    assert "lacks the functions" in native.status()
    _torch_path_still_right()


@needs_cc
def test_cache_folder_others_can_write_to_is_not_used(fresh, monkeypatch):
    monkeypatch.setenv("CC", str(_fake_cc(fresh, _STUB)))
    folder = fresh / "cache" / "native"
    folder.mkdir(parents=True)
    folder.chmod(0o777)
    kernels, messages = _load()
    assert kernels is not None  # built in a private temporary folder instead
    assert len(messages) == 1 and "writable by group or others" in messages[0]
    assert list(folder.iterdir()) == []
    if hasattr(os, "getuid") and os.getuid() == 0:  # as root, also try another owner
        folder.chmod(0o700)
        os.chown(folder, 12345, 12345)
        native.reset()
        kernels, messages = _load()
        assert kernels is not None and len(messages) == 1
        assert "belongs to uid 12345" in messages[0]
        assert list(folder.iterdir()) == []


@needs_cc
def test_sort_kernel_takes_groups_and_grid_offsets_and_refuses_bad_ones():
    # The real kernel (built in the user's cache): groups and shifted grids agree with the slow
    # twin; an offset outside [0, B)^2 is refused (None: the caller falls back), a plan whose
    # positions leave a grouped block raises rather than write out of bounds.
    kernels = native.load()
    if kernels is None:
        pytest.skip(f"native kernels unavailable: {native.status()}")
    gen = torch.Generator().manual_seed(2)
    seeds = torch.randperm(13 * 21, generator=gen).view(13, 21)
    lum = torch.randint(0, 3, (13, 21), generator=gen).float()
    mask = torch.rand(13, 21, generator=gen)
    groups = torch.randint(0, 2, (13, 21), generator=gen)
    for grid in ((0, 0), (2, 1), (3, 3)):
        order = plan_sort(mask, 4, grid).order
        want = sort_pass_reference(seeds, lum, mask, 4, groups=groups, grid_offset=grid)
        got = native.native_sort_blocks(
            kernels, seeds, lum, order, 4, LUMINANCE_WEIGHTS, 2, groups=groups, grid_offset=grid
        )
        assert torch.equal(got, want), grid
    order = plan_sort(mask, 4).order
    bad = native.native_sort_blocks(
        kernels, seeds, lum, order, 4, LUMINANCE_WEIGHTS, grid_offset=(4, 0)
    )
    assert bad is None
    broken = order.clone()
    broken[-1, 0] = 15  # the last block is 1 x 1 (13 x 21 in 4 x 4 blocks): position 15 is off
    with pytest.raises(ValueRangeError, match=r"mask: expected a plan made by plan_sort"):
        native.native_sort_blocks(kernels, seeds, lum, broken, 4, LUMINANCE_WEIGHTS, groups=groups)


def _built_with(monkeypatch, flag: str) -> native.Kernels:
    """The kernels built by ``cc`` with ``flag`` (in the ``fresh`` cache), without a warning;
    the test skips where they cannot be built.

    Built at ``-O0`` instead of the shipped ``-O3``: these builds check that the source's other
    code paths (vector widths, SIMD levels) move the same seeds, which the optimizer may not
    change (``-ffp-contract=off`` keeps the float rounding the same at every level), and
    ``-O0`` compiles in 0.3 s against 10-13 s; the shipped ``-O3`` build is the one the other
    tests load (:func:`bnerr.native.load` in the user's cache)."""
    unoptimized = tuple("-O0" if f == "-O3" else f for f in native_build.FLAGS_NATIVE)
    monkeypatch.setattr(native_build, "FLAGS_NATIVE", unoptimized)
    monkeypatch.setenv("CC", f"cc {flag}")
    kernels, messages = _load(1)
    if kernels is None:
        pytest.skip(f"native kernels unavailable: {native.status()}")
    assert messages == []
    return kernels


@needs_cc
@pytest.mark.parametrize("define", ["-DBNERR_LANES=4", "-DBNERR_NO_SHUFFLE"])
def test_sort_kernel_moves_the_same_seeds_at_another_vector_width(fresh, monkeypatch, define):
    # The kernel's vector width is chosen at build time (8 lanes with AVX2, 16 with AVX-512), and
    # 4 x 4 blocks move between pixel rows and lanes by in-lane shuffles where the compiler has
    # them; a build forced to 4 lanes, or to the scalar transposes, must move the same seeds. The
    # widths cover one full step of lanes and a partial one in every block size. (A 16-lane build
    # is not forced here: without AVX-512 its vectors are emulated and take minutes to compile.)
    kernels = _built_with(monkeypatch, define)
    gen = torch.Generator().manual_seed(5)
    for block in range(2, 9):
        h, w = 2 * block + 1, 17 * block + 3
        color = torch.randint(0, 6, (3, h, w), generator=gen).float() / 5
        color[0, 0, :7], color[1, 1, :3], color[2, 2, :4] = float("nan"), float("inf"), -0.0
        seeds = torch.randperm(h * w, generator=gen).view(h, w)
        mask = torch.rand(h, w, generator=gen)
        for grid in ((0, 0), (1, block - 1)):
            want = sort_pass_reference(seeds, color, mask, block, grid_offset=grid)
            order = plan_sort(mask, block, grid).order
            lum = luminance(color)
            for values in (color, lum):
                got = native.native_sort_blocks(
                    kernels, seeds, values, order, block, LUMINANCE_WEIGHTS, 2, grid_offset=grid
                )
                assert torch.equal(got, want), (define, block, grid, values.ndim)


def _check_retarget_kernel(kernels: native.Kernels) -> None:
    """The native retargeting pass against the torch gather indices, on screens narrower than the
    border band, as wide as the band plus a few pixels, and wide enough for many vectors of the
    interior gather (AVX-512: 8 seeds, AVX2: 4, else scalar) with a scalar head to align its
    stores and a tail; tiles smaller than a vector (3, 5: the tile column wraps more than once a
    vector) and larger; offsets at both ends of the tile; three threads (uneven rows)."""
    gen = torch.Generator().manual_seed(11)
    for size in (3, 5, 8, 12, 16):
        mask = torch.rand(size, size, generator=gen)
        field = optimize_retarget(mask, (1, 2), iterations=30, temperature=1.0, seed=size)
        form = native.retarget_field(field, inverse_field(field))
        reach = form.reach
        for h, w in ((1, 1), (5, 3), (13, 2 * reach + 1), (17, 2 * reach + 9), (29, 77), (9, 203)):
            seeds = torch.randperm(h * w, generator=gen).view(h, w)
            for offset in ((0, 0), (1, size - 1), (size - 1, 2)):
                want = seeds.reshape(-1)[retarget_sources(h, w, field, offset).long()].view(h, w)
                got = native.native_retarget_gather(kernels, seeds, form, offset, threads=3)
                assert torch.equal(got, want), (size, h, w, offset)


@needs_cc
def test_retarget_kernel_equals_the_torch_path_on_wide_screens():
    # The default build (the user's cache): its widest gather.
    kernels = native.load()
    if kernels is None:
        pytest.skip(f"native kernels unavailable: {native.status()}")
    _check_retarget_kernel(kernels)


@needs_cc
@pytest.mark.parametrize("flag", ["-mno-avx512f", "-mno-avx2"])
def test_kernels_move_the_same_seeds_at_a_lower_simd_level(fresh, monkeypatch, flag):
    # The kernels pick their vector code at build time from the compiler's target (-march=native):
    # the sort pass's lanes (16 with AVX-512, 8 with AVX2, else 4) and the retargeting gather
    # (AVX-512, AVX2 or scalar). A build without AVX-512 (an AVX2 host: -mno-avx512f wins over
    # -march=native whatever the order) or without AVX2 must move the same seeds as the torch
    # path, on a host with the wider units as on one without.
    kernels = _built_with(monkeypatch, flag)
    _check_retarget_kernel(kernels)
    gen = torch.Generator().manual_seed(6)
    for block in (2, 4, 5):
        h, w = 3 * block + 2, 37 * block + 3  # two full steps of 16 lanes and a partial one
        color = torch.rand(3, h, w, generator=gen)
        seeds = torch.randperm(h * w, generator=gen).view(h, w)
        mask = torch.rand(h, w, generator=gen)
        for grid in ((0, 0), (1, block - 1)):
            want = sort_pass_reference(seeds, color, mask, block, grid_offset=grid)
            order = plan_sort(mask, block, grid).order
            for values in (color, luminance(color)):
                got = native.native_sort_blocks(
                    kernels, seeds, values, order, block, LUMINANCE_WEIGHTS, 2, grid_offset=grid
                )
                assert torch.equal(got, want), (flag, block, grid, values.ndim)
