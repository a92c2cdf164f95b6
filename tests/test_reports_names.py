"""Structure test: ``benchmarks/reports/`` names no strategy and no denoiser.

The reports read a strategy's family, order, colour, bound-ness and raw-MSE note, and a
denoiser's kind, from the registries (``bnerr.strategies.strategy_identity``,
``denoisers.denoiser_identity``); the few methods their fixed questions are about are named once in
``benchmarks/highlights.py``. A name written as a string in a report module would re-derive an
identity from the name, as the reports did before (``vertical`` drawn as a rival).

Scanned: every string constant of every module (f-string parts included), except docstrings, the
keys of the palette's ``FAMILIES`` table (family names, two of which are also strategy names) and
the arguments of ``denoisers_of_kind`` (kind names: "temporal" is also a strategy's). Forbidden:
every registered strategy and denoiser name, variants included.
"""

from __future__ import annotations

import ast
from pathlib import Path

from bnerr.strategies import STRATEGIES
from denoisers import DENOISERS

_REPORTS = Path(__file__).resolve().parents[3] / "benchmarks" / "reports"
#: Module-level tables keyed by family or kind names, not by strategy or denoiser names.
_FAMILY_TABLES = ("FAMILIES",)
#: Functions whose arguments are family or kind names.
_KIND_LOOKUPS = ("denoisers_of_kind",)


def _exempt(tree: ast.Module) -> set[int]:
    """ids of the docstring constants, the family tables' keys and the kind lookups' arguments
    of a module."""
    out = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            first = body[0] if body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
        target = getattr(node, "target", None) or (getattr(node, "targets", None) or [None])[0]
        value = getattr(node, "value", None)
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) in _KIND_LOOKUPS:
            out |= {id(a) for a in node.args}
        if isinstance(target, ast.Name) and target.id in _FAMILY_TABLES:
            if isinstance(value, ast.Dict):
                out |= {id(k) for k in value.keys if k is not None}
    return out


def name_literals(source: str, names: set[str]) -> list[tuple[int, str]]:
    """``(line, name)`` of every string constant of ``source`` equal to one of ``names``
    (docstrings and family-table keys left out)."""
    tree = ast.parse(source)
    exempt = _exempt(tree)
    return sorted(
        (node.lineno, node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and node.value in names
        and id(node) not in exempt
    )


def test_no_report_module_names_a_strategy_or_a_denoiser():
    names = set(STRATEGIES) | set(DENOISERS)
    found = {
        path.name: hits
        for path in sorted(_REPORTS.glob("*.py"))
        if (hits := name_literals(path.read_text(encoding="utf-8"), names))
    }
    assert not found, f"name literals in benchmarks/reports/ (ask the registry): {found}"


def test_the_scan_finds_names_in_code_and_f_strings_but_not_in_docstrings_or_family_keys():
    source = '''
"""white is the baseline."""
FAMILIES = {"temporal": (0.1, 0.5)}
def f(row):
    """oracle"""
    label = f"{row}" + "taa" + denoisers_of_kind("temporal")
    return row["strategy"] == "white" or row["denoiser"] in ("gaussian", "x")
'''
    names = {"white", "oracle", "temporal", "taa", "gaussian"}
    assert name_literals(source, names) == [(6, "taa"), (7, "gaussian"), (7, "white")]


def test_the_registries_the_scan_reads_hold_the_shipped_names():
    assert {"white", "temporal", "oracle", "vertical", "temporal+relative"} <= set(STRATEGIES)
    assert {"gaussian", "taa", "svgf", "oidn", "unet", "unet_blue"} <= set(DENOISERS)
