"""Tests for the shape of the code base: short functions, no import cycle, imports point one way
(the studies apart from the framework), and no file that refers to a document outside the
repository.

These read the sources with :mod:`ast` (nothing is imported), so they are fast and see function-
level imports as well as module-level ones.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("bnerr", "renderers", "denoisers", "benchmarks")
MAX_FUNCTION_LINES = 60

# Which project package may import which (besides itself): the library stands alone, the renderer
# and the denoisers know only the library, the benchmarks know everything.
ALLOWED_IMPORTS = {
    "bnerr": set(),
    "renderers": {"bnerr"},
    "denoisers": {"bnerr"},
    "benchmarks": {"bnerr", "renderers", "denoisers"},
}


# --------------------------------------------------------------------------------------------
# Reading the sources


def module_files() -> dict[str, Path]:
    """Dotted module name -> source file, for every module of the four packages."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join(parts)] = path
    return modules


MODULES = module_files()


def parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def span(node: ast.FunctionDef | ast.AsyncFunctionDef) -> tuple[int, int]:
    """``(first line, lines)`` of a function: from its first decorator (else its ``def``) to the
    end of its body, every line counted: docstrings, comments and blank lines are read too."""
    first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
    end = node.end_lineno if node.end_lineno is not None else node.lineno
    return first, end - first + 1


def function_lengths(tree: ast.Module) -> list[tuple[str, int, int]]:
    """``(qualified name, first line, lines)`` of every function and method, nested ones too
    (:func:`span`; a nested function's lines count in its parent's as well)."""
    found = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = f"{prefix}{child.name}"
                found.append((name, *span(child)))
                visit(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(tree, "")
    return found


def _type_checking_only(tree: ast.Module) -> set[int]:
    """``id`` of every import node guarded by ``if TYPE_CHECKING:`` (never run)."""
    guarded = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            test = node.test
            name = getattr(test, "id", None) or getattr(test, "attr", None)
            if name == "TYPE_CHECKING":
                for inner in node.body:
                    guarded.update(id(n) for n in ast.walk(inner))
    return guarded


def _resolve(module: str, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` names (relative imports resolved)."""
    if node.level == 0:
        return node.module or ""
    is_package = MODULES[module].name == "__init__.py"
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def _project_module(name: str) -> str | None:
    """``name`` if it is a project module, else its longest project-module prefix, else None."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        candidate = ".".join(parts[:k])
        if candidate in MODULES:
            return candidate
    return None


def imports_of(module: str, *, runtime_only: bool) -> set[str]:
    """Project modules that ``module`` imports anywhere in its file (functions included).

    ``from x import y`` counts as an import of ``x.y`` when that is a module, else of ``x``.
    With ``runtime_only``, imports under ``if TYPE_CHECKING:`` are left out.
    """
    tree = parse(MODULES[module])
    skip = _type_checking_only(tree) if runtime_only else set()
    targets: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(module, node)
            names = [f"{base}.{alias.name}" if alias.name != "*" else base for alias in node.names]
        else:
            continue
        for name in names:
            target = _project_module(name)
            if target is not None and target != module:
                targets.add(target)
    return targets


def import_graph(*, runtime_only: bool = True) -> dict[str, set[str]]:
    return {m: imports_of(m, runtime_only=runtime_only) for m in MODULES}


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle (``[a, b, ..., a]``) per strongly connected component that has one (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return [_cycle_in(graph, set(c), c[0]) for c in components]


def _cycle_in(graph: dict[str, set[str]], component: set[str], start: str) -> list[str]:
    """A shortest cycle through ``start`` inside ``component`` (breadth-first)."""
    parent = {start: None}
    frontier = [start]
    while frontier:
        following = []
        for v in frontier:
            for w in sorted(graph[v] & component):
                if w == start:
                    path = [v]
                    while parent[path[-1]] is not None:
                        path.append(parent[path[-1]])
                    return [*reversed(path), start]
                if w not in parent:
                    parent[w] = v
                    following.append(w)
        frontier = following
    raise AssertionError(f"no cycle through {start}")  # Tarjan said there is one


# --------------------------------------------------------------------------------------------
# The tests


def test_no_function_is_longer_than_60_lines():
    too_long = []
    for path in MODULES.values():
        for name, line, length in function_lengths(parse(path)):
            if length > MAX_FUNCTION_LINES:
                too_long.append(f"{path.relative_to(ROOT)}:{line} {name} ({length} lines)")
    assert not too_long, "functions over 60 lines:\n" + "\n".join(too_long)


def test_function_length_counts_every_line_from_the_first_decorator():
    source = (
        '@decorator\n@other(1)\ndef f(x):\n    """Doc\n    string."""\n\n    # why\n'
        "    y = (x,\n         'not a docstring')\n    return y\n"
    )
    assert function_lengths(ast.parse(source)) == [("f", 1, 10)]
    nested = (
        "class A:\n    def m(self):\n        def inner():\n            '''Doc.'''\n"
        "            pass\n        return 1\n"
    )
    assert function_lengths(ast.parse(nested)) == [("A.m", 2, 5), ("A.m.inner", 3, 3)]


def test_no_import_cycle():
    cycles = find_cycles(import_graph())
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_no_import_cycle_even_through_type_only_imports():
    """An import under ``if TYPE_CHECKING:`` never runs, but a circle through one still says two
    modules each need the other: the layering is wrong, whatever the interpreter allows."""
    cycles = find_cycles(import_graph(runtime_only=False))
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def _parent(module: str) -> str:
    """The package a module belongs to (a package's ``__init__`` belongs to itself)."""
    return module if MODULES[module].name == "__init__.py" else module.rpartition(".")[0]


def private_imports(module: str) -> list[str]:
    """``from X import _name`` in ``module``, X another project module: a name another module
    needs is shared API and gets a public name in its owner. The modules of one subpackage
    (``bnerr.sequences``, ``benchmarks.sweep``: a folder with its own base module) may share
    private helpers among themselves; the flat top-level packages may not."""
    found = []
    for node in ast.walk(parse(MODULES[module])):
        if not isinstance(node, ast.ImportFrom):
            continue
        source = _project_module(_resolve(module, node))
        if source is None or source == module:
            continue
        family = _parent(source)
        if family == _parent(module) and "." in family:
            continue
        for alias in node.names:
            if alias.name.startswith("_") and not alias.name.startswith("__"):
                found.append(f"{module}:{node.lineno} imports {alias.name} from {source}")
    return found


def test_no_module_imports_a_private_name_from_another_module():
    found = [hit for module in MODULES for hit in private_imports(module)]
    assert not found, "private names imported from other modules:\n" + "\n".join(found)


def test_the_cycle_finder_finds_cycles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"f"}, "f": {"e"}}
    assert find_cycles(graph) == [["a", "b", "c", "a"], ["e", "f", "e"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_imports_are_resolved_to_submodules_relative_and_function_level_ones_included():
    assert _resolve("bnerr.io", ast.ImportFrom(module="errors", names=[], level=1)) == (
        "bnerr.errors"
    )
    assert _resolve("bnerr", ast.ImportFrom(module="masks", names=[], level=1)) == "bnerr.masks"
    assert _resolve("bnerr.masks", ast.ImportFrom(module="stbn", names=[], level=1)) == (
        "bnerr.masks.stbn"
    )  # a package's __init__ resolves inside itself
    assert _resolve("bnerr.masks.fast", ast.ImportFrom(module=None, names=[], level=2)) == "bnerr"
    assert _resolve("bnerr.io", ast.ImportFrom(module=None, names=[], level=2)) == ""
    assert _project_module("bnerr.errors.check_shape") == "bnerr.errors"
    assert _project_module("numpy.linalg") is None
    graph = import_graph()
    assert {"bnerr.errors", "bnerr.resources"} <= graph["bnerr.masks.spatial"]
    assert graph["bnerr.masks"] == {"bnerr.masks.spatial"}
    assert all(m in MODULES for targets in graph.values() for m in targets)
    source = "def f():\n    from bnerr import errors\n    import renderers.tracer as t\n"
    tree = ast.parse(source)
    imports = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))]
    assert len(imports) == 2  # ast.walk reaches into function bodies


def test_imports_point_one_way():
    wrong = []
    for module, targets in import_graph(runtime_only=False).items():
        package = module.split(".")[0]
        for target in sorted(targets):
            other = target.split(".")[0]
            if other != package and other not in ALLOWED_IMPORTS[package]:
                wrong.append(f"{module} imports {target}")
    assert not wrong, "imports against the layering:\n" + "\n".join(wrong)


# The studies (benchmarks/studies/): each the measurement behind one finding, run once by hand.
STUDIES = "benchmarks.studies"


def is_study(module: str) -> bool:
    return module == STUDIES or module.startswith(f"{STUDIES}.")


def import_closure(roots: list[str], graph: dict[str, set[str]]) -> set[str]:
    """Every module that importing ``roots`` can load: the roots and, transitively, what they
    import (function-level and type-only imports included, as in ``graph``)."""
    seen: set[str] = set()
    stack = list(roots)
    while stack:
        module = stack.pop()
        if module not in seen:
            seen.add(module)
            stack.extend(graph.get(module, ()))
    return seen


def test_the_import_closure_follows_imports_transitively():
    graph = {"a": {"b"}, "b": {"c"}, "c": set(), "d": {"a"}}
    assert import_closure(["a"], graph) == {"a", "b", "c"}
    assert import_closure(["d", "c"], graph) == {"a", "b", "c", "d"}
    assert is_study("benchmarks.studies.x") and is_study(STUDIES)
    assert not is_study("benchmarks.studies_x") and not is_study("benchmarks.suites")


def test_no_module_outside_the_studies_imports_a_study():
    """A study answers a question once; the library, the renderers, the denoisers and the
    benchmark framework never need one (a helper two of them share moves into the framework)."""
    wrong = [
        f"{module} imports {target}"
        for module, targets in import_graph(runtime_only=False).items()
        if not is_study(module)
        for target in sorted(targets)
        if is_study(target)
    ]
    assert not wrong, "studies imported from outside benchmarks/studies:\n" + "\n".join(wrong)


def test_the_bench_never_loads_a_study():
    """``bnerr``'s commands (``benchmarks.cli`` and every module of ``benchmarks.commands``, which
    the CLI discovers by name, not by an import statement) and the suites load no study: a module
    the bench needs does not sit among the studies."""
    graph = import_graph(runtime_only=False)
    commands = [m for m in MODULES if m.startswith("benchmarks.commands.")]
    loaded = import_closure(["benchmarks.cli", "benchmarks.suites", *commands], graph)
    # the closure is deep
    assert {"benchmarks.sweep.runner", "benchmarks.commands.eval.evaluate"} <= loaded
    studies = sorted(m for m in loaded if is_study(m))
    assert not studies, "studies the bench loads (framework modules?): " + ", ".join(studies)


def test_every_study_runs_as_a_module_and_names_its_command_and_finding():
    """Each study runs as ``python -m benchmarks.studies.NAME``, its docstring quotes that command
    and names the finding it measures in docs/FINDINGS.md, and FINDINGS quotes the command."""
    findings = " ".join((ROOT / "docs" / "FINDINGS.md").read_text(encoding="utf-8").split())
    studies = [m for m, path in MODULES.items() if is_study(m) and path.name != "__init__.py"]
    assert len(studies) >= 8
    wrong = []
    for module in studies:
        tree = parse(MODULES[module])
        doc = " ".join((ast.get_docstring(tree) or "").split())
        command = f"python -m {module}"
        runs = any(
            isinstance(node, ast.If) and "__main__" in ast.unparse(node.test) for node in tree.body
        )
        if not runs:
            wrong.append(f'{module}: no `if __name__ == "__main__":`')
        if command not in doc or "docs/FINDINGS.md" not in doc:
            wrong.append(f"{module}: its docstring quotes no `{command}` or no docs/FINDINGS.md")
        if command not in findings:
            wrong.append(f"{module}: docs/FINDINGS.md quotes no `{command}`")
    assert not wrong, "studies:\n" + "\n".join(wrong)


# Files that could refer to a document: sources, docs, configuration, the Makefile and CI.
_SCANNED = re.compile(r"(\.py|\.md|\.toml)$|(^|/)Makefile$|^\.ci/")
_EXCLUDED_DIRS = {".git", "results", ".venv", "cache", "out", "build", ".hypothesis"}
# Written in two pieces so that this file does not match its own patterns.
_OUTSIDE = "shared" + "/"
_DOC = re.compile(r"(\S*?)\b(" + "METHODS|STYLE|ARCHITECTURE|ZSOBOL" + r")\.md")


def repository_files() -> list[Path]:
    """The repository's files that :data:`_SCANNED` selects, outside results/ and .git.

    From git (tracked files and untracked ones not ignored) when it is available, else a walk of
    the tree that skips the usual build and cache folders.
    """
    try:
        listed = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.splitlines()
    except (OSError, subprocess.CalledProcessError):
        listed = _walk_tree()
    return sorted(
        ROOT / rel
        for rel in listed
        if _SCANNED.search(rel)
        and rel.split("/")[0] not in _EXCLUDED_DIRS
        and (ROOT / rel).is_file()
    )


def _walk_tree() -> list[str]:
    """Every file under the repository root, relative, skipping :data:`_EXCLUDED_DIRS`."""
    listed = []
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in _EXCLUDED_DIRS and not d.endswith(".egg-info")]
        listed += [str((Path(folder) / f).relative_to(ROOT)) for f in files]
    return listed


def outside_references(text: str) -> list[str]:
    """The references in ``text`` to documents that are not in the repository."""
    found = [f"'{_OUTSIDE}'"] * text.count(_OUTSIDE)
    for match in _DOC.finditer(text):
        prefix, name = match.group(1), match.group(2)
        in_docs = prefix.endswith("docs/") and prefix.lstrip("`'\"([]") == "docs/"
        if not (in_docs and (ROOT / "docs" / f"{name}.md").is_file()):
            found.append(match.group(0))
    return found


def test_reference_finder():
    methods, style = "METH" + "ODS.md", "STY" + "LE.md"  # in pieces, as above
    assert outside_references(f"see docs/{methods}, section 2") == []
    assert outside_references(f"(`docs/{methods}`)") == []
    assert outside_references(f"{methods} section 2") == [methods]
    assert outside_references(f"../docs/{methods}") == [f"../docs/{methods}"]
    assert outside_references(f"docs/{style}") == [f"docs/{style}"]  # not in the repository
    assert outside_references(f"[docs/{methods}]({methods})") == [f"]({methods}"]
    assert outside_references(f"[`docs/{methods}`](docs/{methods})") == []  # a link from the root
    assert len(outside_references("/work/" + _OUTSIDE + "docs")) == 1


def test_no_file_refers_to_a_document_outside_the_repository():
    files = repository_files()
    assert any(p.name == "README.md" for p in files) and any(p.suffix == ".py" for p in files)
    offenders = []
    for path in files:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for ref in outside_references(line):
                offenders.append(f"{path.relative_to(ROOT)}:{number}: {ref}")
    assert not offenders, "references to documents outside the repository:\n" + "\n".join(offenders)


_CONFLICT = re.compile(r"^(<{7} |>{7} |={7}$)")


def test_no_file_keeps_a_merge_conflict_marker():
    # A conflict left in a Markdown file breaks no import and no other test: only this finds it.
    offenders = [
        f"{path.relative_to(ROOT)}:{number}"
        for path in repository_files()
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if _CONFLICT.match(line)
    ]
    assert not offenders, "merge conflict markers:\n" + "\n".join(offenders)
    assert _CONFLICT.match("<" * 7 + " HEAD") and not _CONFLICT.match("=" * 8)


@pytest.mark.parametrize("name", ["METHODS", "ARCHITECTURE", "INTERFACES"])
def test_the_project_docs_exist(name):
    assert (ROOT / "docs" / f"{name}.md").is_file()


def test_the_longest_test_files_named_first_exist():
    # tests/conftest.py runs them first (make test's scheduling); a renamed file would silently
    # fall back to its collection place.
    from tests.conftest import LONGEST_FIRST

    assert LONGEST_FIRST and all((ROOT / path).is_file() for path in LONGEST_FIRST)
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)
