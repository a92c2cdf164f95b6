"""``bnerr scenes``: list the named scenes with their dimension counts, depth and what they model.

bnerr scenes
bnerr scenes --layout medium     # which sampler dimension feeds which decision
"""

from __future__ import annotations

import argparse
from typing import TypedDict

from renderers import SCENES, get_scene

__all__ = ["SceneRow", "register", "run", "table"]


class SceneRow(TypedDict):
    """One named scene in the table."""

    name: str
    D: int
    depth: int
    lights: int
    objects: int
    medium: bool
    description: str


def table() -> list[SceneRow]:
    """One row per named scene: name, D, depth, lights, objects, medium, description."""

    rows: list[SceneRow] = []
    for name in SCENES:
        scene = get_scene(name)
        rows.append(
            {
                "name": name,
                "D": scene.dimensions,
                "depth": scene.max_depth,
                # a scene that renders itself (a Mitsuba XML plug-in) does not list its parts
                "lights": len(getattr(scene, "lights", ())),
                "objects": len(getattr(scene, "shapes", ())),
                "medium": getattr(scene, "medium", None) is not None,
                "description": scene.description,
            }
        )
    return rows


def run(args: argparse.Namespace) -> int:

    if args.layout:
        scene = get_scene(args.layout)
        print(
            f"{scene.name}: D = {scene.dimensions}, "
            f"max_depth = {scene.max_depth} (Mitsuba's convention)"
        )
        for line in scene.layout.describe():
            print(f"  {line}")
        return 0
    rows = table()
    width = max(len(r["name"]) for r in rows)
    print(
        f"{'name':<{width}}  {'D':>3}  {'depth':>5}  {'lights':>6}  {'medium':>6}  what it models"
    )
    for r in rows:
        print(
            f"{r['name']:<{width}}  {r['D']:>3}  {r['depth']:>5}  {r['lights']:>6}  "
            f"{'yes' if r['medium'] else 'no':>6}  {r['description']}"
        )
    print(
        "\ndepth: Mitsuba's max_depth (segments of the longest path; 2 = direct light only). "
        "Every scene is animated over t; --static in bnerr render freezes it at t = 0."
    )
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "scenes",
        help="list the named scenes with their dimension counts",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("--layout", metavar="SCENE", help="print the dimension layout of one scene")
    p.set_defaults(func=run)
