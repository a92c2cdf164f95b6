"""Tests for bnerr._moved: every old module path imports as its new module, with one
DeprecationWarning that names the new path and the importing line, and nothing in the project
imports an old path."""

from __future__ import annotations

import ast
import importlib
import importlib.machinery
import re
import sys
import tomllib
import warnings
from pathlib import Path

import pytest

import bnerr
from bnerr._moved import MOVED, MovedFinder, install
from tests.test_structure import MODULES, ROOT, parse


@pytest.fixture
def forgotten():
    """Forget the old paths before and after the test, so that each import goes through the
    finder (Python caches a module under its old name, and as an attribute of ``bnerr``)."""

    def forget() -> None:
        for old in MOVED:
            sys.modules.pop(old, None)
            vars(bnerr).pop(old.rpartition(".")[2], None)

    forget()
    yield
    forget()


def _deprecations(record: pytest.WarningsRecorder) -> list[warnings.WarningMessage]:
    return [w for w in record if issubclass(w.category, DeprecationWarning)]


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_path_is_the_new_module_with_one_warning_naming_it(old, forgotten):
    new = MOVED[old]
    message = rf"^{re.escape(old)} is deprecated: import {re.escape(new)} instead"
    namespace: dict[str, object] = {}
    with pytest.warns(DeprecationWarning, match=message) as record:
        exec(f"import {old} as module", namespace)
    (warning,) = _deprecations(record)
    assert warning.filename == "<string>"  # the importing line, not the import system's
    assert namespace["module"] is importlib.import_module(new)
    assert sys.modules[old] is sys.modules[new]
    assert getattr(bnerr, old.split(".")[1]) is sys.modules[new]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(f"import {old}", {})  # cached: no second warning


def test_every_form_of_import_works_and_warns_once(forgotten):
    from bnerr.permutation.permute import sort_pass
    from bnerr.permutation.retarget import Retarget

    with pytest.warns(DeprecationWarning) as record:
        import bnerr.permute
        from bnerr import retarget
        from bnerr.permute import sort_pass as old_sort_pass
        from bnerr.retarget import Retarget as OldRetarget
    assert [Path(w.filename).name for w in _deprecations(record)] == [Path(__file__).name] * 2
    assert old_sort_pass is sort_pass and bnerr.permute.sort_pass is sort_pass
    assert OldRetarget is Retarget and retarget.Retarget is Retarget


def test_the_names_of_the_old_modules_are_there():
    """``bnerr.masks`` did not move: it is the package, with every name the module had."""
    import bnerr.masks
    import bnerr.masks.spatial

    assert bnerr.masks.__all__ == bnerr.masks.spatial.__all__
    assert all(
        getattr(bnerr.masks, n) is getattr(bnerr.masks.spatial, n) for n in bnerr.masks.__all__
    )
    spectrum = importlib.import_module("bnerr.metrics.spectrum")
    assert {"low_frequency_fraction", "radial_power_spectrum"} <= set(spectrum.__all__)


def test_the_table_names_modules_that_exist_and_files_that_do_not():
    for old, new in MOVED.items():
        assert importlib.util.find_spec(new) is not None, new
        assert not (ROOT / Path(*old.split("."))).with_suffix(".py").exists(), old
        assert not (ROOT / Path(*old.split("."))).is_dir(), old
    assert "bnerr.masks" not in MOVED


def test_the_finder_answers_only_for_the_old_paths_and_is_installed_once():
    finder = MovedFinder()
    assert finder.find_spec("bnerr.permutation.permute", None) is None
    assert finder.find_spec("bnerr.nothing", None) is None
    assert finder.find_spec("bnerr.permute", None).name == "bnerr.permute"
    with pytest.raises(ModuleNotFoundError, match="bnerr.nothing"):
        importlib.import_module("bnerr.nothing")
    install()
    install()
    finders = [f for f in sys.meta_path if isinstance(f, MovedFinder)]
    assert len(finders) == 1
    # before the path's finder and any after it (an editable install's, which would find old files)
    assert sys.meta_path.index(finders[0]) < sys.meta_path.index(importlib.machinery.PathFinder)


def test_the_test_suite_fails_on_the_warning_outside_pytest_warns(forgotten):
    """pyproject.toml's ``filterwarnings`` turns the warning into an error, so a test that runs
    project code importing an old path fails."""
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    rules = pyproject["tool"]["pytest"]["ini_options"]["filterwarnings"]
    (rule,) = [r for r in rules if "is deprecated" in r]
    action, message, category = rule.split(":")
    assert (action, category) == ("error", "DeprecationWarning")
    with warnings.catch_warnings():
        warnings.filterwarnings(action, message, DeprecationWarning)
        with pytest.raises(DeprecationWarning, match="import bnerr.permutation.vertical instead"):
            importlib.import_module("bnerr.vertical")
    assert "bnerr.vertical" not in sys.modules  # a failed import leaves nothing behind


def _old_imports(path: Path) -> list[str]:
    """The old paths that the file at ``path`` imports, or names as a string (``import_module``)."""
    found = []
    for node in ast.walk(parse(path)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module, *(f"{node.module}.{alias.name}" for alias in node.names)]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            names = [node.value]
        else:
            continue
        found += [f"{path.relative_to(ROOT)}:{node.lineno} {n}" for n in names if n in MOVED]
    return found


def test_no_module_or_test_of_the_project_uses_an_old_path():
    files = [*MODULES.values(), *sorted((ROOT / "tests").rglob("*.py"))]
    found = [hit for path in files if path != Path(__file__) for hit in _old_imports(path)]
    found = [hit for hit in found if not hit.startswith("bnerr/_moved.py:")]
    assert not found, "imports of moved paths:\n" + "\n".join(found)
    sample = ROOT / "tests" / "bnerr" / "test_moved.py"
    assert _old_imports(sample)  # this file's own imports are found
