"""``bnerr`` command lines run in the test process, as a fresh ``bnerr`` process would run them: the
doc-page tests (tests/benchmarks/commands/test_bench_docs.py and eval/test_command_docs.py) run
every command of a page this way but one, which they run through a shell and the console script.

A ``bnerr`` process pays about 4.7 s of CPU importing torch, kornia and scipy before it starts;
the pages' commands themselves take a fraction of that at their tiny sizes. In the test process
the imports are paid once. What a new process would not carry over is put back after each
command (:func:`fresh_process`): the plug-in registries and their entry-point scans, the loaded
plug-in files (a page that then edits ``my_plugins.py`` must see the edit), the working folder,
``sys.path`` and torch's thread count.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import pytest
import torch

#: What a shell would read as more than one program's arguments: such a line runs in a shell.
SHELL_SYNTAX = set("<>|&;$`(){}*?~")


def _registries() -> list:
    """The plug-in registries (the ones tests/conftest.py's ``forget`` fixture knows)."""
    import denoisers
    import renderers
    from bnerr import sequences
    from bnerr.metrics import METRIC_TABLE

    return [denoisers.DENOISERS, renderers.SCENES, sequences.SAMPLERS, METRIC_TABLE]


def _clear_plugin_caches() -> None:
    """Forget every entry-point scan and resolved spec, as a new process starts without them."""
    from bnerr import plugins

    for cached in (plugins.installed, plugins._resolve, plugins._top_level_distributions):
        cached.cache_clear()


def _plugin_modules(folders: Sequence[Path], before: set[str]) -> list[str]:
    """The modules plug-ins were imported as since ``before``: files under ``folders`` and
    bnerr's own names for plug-in files (:func:`bnerr.plugins.file_module_name`)."""
    roots = [str(Path(f).resolve()) + os.sep for f in folders]
    found = []
    for name, module in list(sys.modules.items()):
        file = getattr(module, "__file__", None) or ""
        plugin = name.startswith("bnerr_plugin_") or any(file.startswith(r) for r in roots)
        if plugin and name not in before:
            found.append(name)
    return found


@contextlib.contextmanager
def fresh_process(cwd: Path, path: Sequence[Path] = ()) -> Iterator[None]:
    """Run the body as a new ``bnerr`` process started in ``cwd`` with ``path`` on PYTHONPATH
    would, and put the test process back as it was afterwards."""
    from bnerr import plugins
    from bnerr.strategies import REGISTRY

    registries = [(r, dict(dict.items(r)), r._state) for r in _registries()]
    strategies = (dict(REGISTRY._classes), dict(REGISTRY._variants), REGISTRY._installed)
    loaded, threads = dict(plugins._LOADED), torch.get_num_threads()
    saved_path, saved_cwd, modules = list(sys.path), os.getcwd(), set(sys.modules)
    sys.path[:0] = [str(p) for p in path]
    for registry, _, _ in registries:  # read the entry points again, with ``path`` on sys.path
        registry._state = "new"
    REGISTRY._installed = False
    _clear_plugin_caches()
    os.chdir(cwd)
    try:
        yield
    finally:
        os.chdir(saved_cwd)
        sys.path[:] = saved_path
        torch.set_num_threads(threads)
        for registry, entries, state in registries:
            dict.clear(registry)
            dict.update(registry, entries)
            registry._state = state
        REGISTRY._classes, REGISTRY._variants, REGISTRY._installed = strategies
        plugins._LOADED.clear()
        plugins._LOADED.update(loaded)
        _clear_plugin_caches()
        for name in _plugin_modules([cwd, *path], modules):
            del sys.modules[name]


def _exit_code(argv: list[str]) -> int:
    """``bnerr ARGV``'s exit status, as the console script's process would end with it."""
    from benchmarks.cli import main

    try:
        return main(argv)
    except SystemExit as done:  # argparse's --help and --version, a plug-in's sys.exit()
        if done.code is None or isinstance(done.code, int):
            return done.code or 0
        print(done.code, file=sys.stderr)
        return 1


def bnerr_in_process(
    line: str, capsys: pytest.CaptureFixture, cwd: Path, path: Sequence[Path] = ()
) -> tuple[int, str, str]:
    """Run the command line ``line`` (``bnerr ...``, split as a shell would: :func:`shlex.split`)
    in this process from ``cwd`` with ``path`` on ``sys.path``; its exit status, stdout and
    stderr."""
    argv = shlex.split(line)
    assert argv[0] == "bnerr" and not SHELL_SYNTAX & set(line), f"not one bnerr command: {line}"
    capsys.readouterr()
    with fresh_process(cwd, path):
        code = _exit_code(argv[1:])
    out, err = capsys.readouterr()
    return code, out, err
