"""``bnerr schema``: print the JSON Schema of a file format, for an editor to check files with.

bnerr schema scene > scene.schema.json       # scene files (docs/SCENE_FILES.md)
bnerr schema eval > eval.schema.json         # a frame folder's manifest.toml (docs/EVAL.md)

The formats: scene, camera (the camera sidecar of a Mitsuba XML scene), eval, renderer (the
seed protocol's manifest) and denoiser (an executable denoiser's manifest). The schema is made
from the same models the loaders validate with (:mod:`bnerr.schemas`), so what the editor flags
the loader refuses; a few checks need more than one file (the camera's pose over the frames, a
program's path), and those only the loader makes.
"""

from __future__ import annotations

import argparse
import json

from bnerr.schemas import FORMATS, json_schema

__all__ = ["register", "run"]


def run(args: argparse.Namespace) -> int:
    print(json.dumps(json_schema(args.format), indent=2))
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "schema",
        help="print the JSON Schema of a file format (scene, eval, ...)",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("format", choices=list(FORMATS), help="the file format")
    p.set_defaults(func=run)
