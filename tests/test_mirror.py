"""The test tree mirrors the source tree: every module has ``tests/<its path>/test_<name>.py`` (or
names the neighbour file that covers it), every test file is named after a module of its mirrored
folder, and every test folder is a package. Like tests/test_structure.py (whose module index this
reads), nothing is imported but the sources' syntax trees."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.test_structure import MODULES, ROOT, parse

TESTS = ROOT / "tests"

#: Modules whose tests live in a neighbour's file, and why: module -> (that file, reason). A module
#: that defines no function or class (a re-export, a table of constants) needs no entry; every
#: other module without ``tests/<its folder>/test_<its name>.py`` must be named here.
MIRROR_EXEMPT = {
    "benchmarks/commands/_args.py": (
        "tests/benchmarks/test_cli_options.py", "every command's options, tried from one table"
    ),
    "benchmarks/commands/_mask_ldbn.py": (
        "tests/benchmarks/commands/test_mask.py", "``bnerr mask --ldbn`` is its only caller"
    ),
    "benchmarks/reports/__init__.py": (
        "tests/benchmarks/reports/test_table.py", "write_report writes the tables tested there"
    ),
    **{
        f"benchmarks/speed/{name}.py": (
            "tests/benchmarks/speed/test_init.py",
            "run_speed and the tables of the shipped figures; the timings themselves take minutes",
        )
        for name in ("copy", "formatting")
    },
    "benchmarks/sweep/tuning.py": (
        "tests/benchmarks/sweep/test_measure.py", "the denoisers are tuned there with stand-ins"
    ),
    "benchmarks/sweep/version.py": (
        "tests/benchmarks/sweep/test_references.py", "the version keys the reference cache"
    ),
    "bnerr/native/__init__.py": (
        "tests/bnerr/native/test_build.py", "the loader and the disable switch, with the build"
    ),
    "bnerr/sequences/base.py": (
        "tests/bnerr/sequences/test_init.py", "the Sampler interface, through every sampler"
    ),
    "bnerr/sequences/tables.py": (
        "tests/bnerr/sequences/test_owen_sobol.py", "the sampler's nets, from these tables"
    ),
    "bnerr/sequences/white.py": (
        "tests/bnerr/sequences/test_init.py", "white and Owen-Sobol against one Python twin"
    ),
    "denoisers/base.py": ("tests/denoisers/test_init.py", "the interface, through every denoiser"),
    "denoisers/native/__init__.py": (
        "tests/denoisers/native/test_filters.py", "the kernels it loads, their thread count"
    ),
}  # fmt: skip

#: Test files that test several modules together, under no one module's name.
CROSS_CUTTING = {
    "tests/benchmarks/reports/test_identity_end_to_end.py": (
        "a new strategy and denoiser through every report"
    ),
    "tests/benchmarks/sweep/test_ordering.py": "oracle < temporal < white end to end",
    "tests/benchmarks/sweep/test_ordering_coherent.py": "the same in coherent regions",
    "tests/benchmarks/sweep/test_ordering_failures.py": "temporal on its failure cases, end to end",
    "tests/benchmarks/sweep/test_ordering_rivals.py": "the a-priori rivals against white",
    "tests/benchmarks/sweep/test_ordering_variants.py": "the temporal variants, end to end",
    "tests/test_cuda.py": "strategies, tracer, denoisers, metrics and a sweep on CUDA vs the CPU",
}


def defines_code(path: Path) -> bool:
    """Whether a module defines a function or a class (else it only re-exports or lists)."""
    kinds = (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)
    return any(isinstance(node, kinds) for node in parse(path).body)


def mirrored_test(path: Path) -> Path:
    """``bnerr/strategies/white.py`` -> ``tests/bnerr/strategies/test_white.py``; a package's
    ``__init__.py`` -> ``test_init.py``, ``_args.py`` -> ``test_args.py``."""
    relative = path.relative_to(ROOT)
    return TESTS / relative.parent / f"test_{relative.stem.strip('_')}.py"


def test_every_module_has_its_mirrored_test_file_or_names_the_neighbour_that_covers_it():
    missing = []
    for path in MODULES.values():
        key = str(path.relative_to(ROOT))
        if mirrored_test(path).is_file():
            assert key not in MIRROR_EXEMPT, f"{key} has its own test file: drop its exemption"
        elif defines_code(path) and key not in MIRROR_EXEMPT:
            missing.append(f"{key}: no {mirrored_test(path).relative_to(ROOT)}")
    assert not missing, "modules without a test file:\n" + "\n".join(missing)
    sources = {str(path.relative_to(ROOT)) for path in MODULES.values()}
    for module, (neighbour, reason) in MIRROR_EXEMPT.items():
        assert module in sources, f"MIRROR_EXEMPT names {module}, which no longer exists"
        assert (ROOT / neighbour).is_file() and reason, f"{module}: no {neighbour}"


def test_every_test_file_is_named_after_a_module_of_its_mirrored_folder():
    """``tests/<folder>/test_<module>.py`` or ``test_<module>_<aspect>.py`` (e.g.
    ``test_tracer_properties.py``, ``test_cli_options.py``): a file named after a module that no
    longer exists, or put in the wrong folder, fails here."""
    wrong = []
    for test in sorted(TESTS.rglob("test_*.py")):
        key = str(test.relative_to(ROOT))
        if test.parent == TESTS or key in CROSS_CUTTING:
            continue  # the house's own tests (this file) and the listed end-to-end ones
        folder = ROOT / test.parent.relative_to(TESTS)
        names = {p.stem.strip("_") for p in folder.glob("*.py")}
        tested = test.stem.removeprefix("test_")
        if not any(tested == name or tested.startswith(f"{name}_") for name in names):
            wrong.append(f"{key}: no module {tested!r} (or a prefix of it) in {folder.name}/")
    assert not wrong, "test files not named after a module:\n" + "\n".join(wrong)
    for key in CROSS_CUTTING:
        assert (ROOT / key).is_file(), f"CROSS_CUTTING names {key}, which no longer exists"


def test_every_test_folder_is_a_package_so_none_shadows_a_source_package():
    """With ``tests/__init__.py`` pytest imports ``tests/bnerr/test_io.py`` as
    ``tests.bnerr.test_io`` with the repo root on ``sys.path``; a folder without one would be put
    on ``sys.path`` itself and its ``bnerr/`` would hide the real package (or two ``test_init.py``
    would collide)."""
    folders = [TESTS, *(p for p in TESTS.rglob("*") if p.is_dir() and p.name != "__pycache__")]
    missing = [str(p.relative_to(ROOT)) for p in folders if not (p / "__init__.py").is_file()]
    assert not missing, "test folders without __init__.py: " + ", ".join(missing)
    assert mirrored_test(ROOT / "bnerr/__init__.py") == TESTS / "bnerr" / "test_init.py"
