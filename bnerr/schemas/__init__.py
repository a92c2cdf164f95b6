"""One typed model per file a user writes, and the JSON Schema an editor checks it against.

- :mod:`bnerr.schemas.scene`: the scene file (TOML or JSON; docs/SCENE_FILES.md);
- :mod:`bnerr.schemas.camera`: the camera sidecar of a Mitsuba XML scene;
- :mod:`bnerr.schemas.eval`: the frame folder's ``manifest.toml`` that ``bnerr eval`` reads;
- :mod:`bnerr.schemas.renderer`: the manifest of a renderer driven by the seed protocol;
- :mod:`bnerr.schemas.denoiser`: the manifest of an executable denoiser.

Each loader parses its file (TOML or JSON), validates the document against its model with
:func:`bnerr.schemas.errors.validate`, which turns the first problem into bnerr's one-line typed
error (``shapes[3].radius: expected a finite number in [1e-06, 1000000.0], got float -0.7``),
then checks what needs more than the document (a scene's geometry, a program's file). The
building blocks (a table with known keys only, finite numbers in a range, names) are in
:mod:`bnerr.schemas.fields`. :func:`json_schema` is what ``bnerr schema NAME`` prints.

Why pydantic 2 and not msgspec (measured here, pydantic 2.14, msgspec 0.23): both validate a
parsed document into typed classes and publish a JSON Schema. msgspec is the lighter (0.6 MB
installed, no dependency; pydantic and its core 7 MB) and the faster (a 50-shape document of
spheres validated in 6.4 us against 34 us), but it reports a failure as one preformatted string
(``Expected `float` >= 1e-06 - at `$.shapes[3].radius```), from which bnerr's wording and error
class would have to be parsed back. pydantic 2 gives each failure's location, type and input
apart, lets a check raise its own message (``PydanticCustomError``) and lets a type add to its
JSON Schema. Its cost is start-up: importing it takes 0.08 s and building the scene model 0.23 s
(paid only by commands that read such a file); validating ``examples/scenes/cornell.toml`` then
takes 0.2 ms, nothing beside reading the file.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["FORMATS", "json_schema"]

#: The formats ``bnerr schema`` knows: name -> (module of :mod:`bnerr.schemas`, its model).
FORMATS: dict[str, tuple[str, str]] = {
    "scene": ("scene", "SceneDocument"),
    "camera": ("camera", "CameraPath"),
    "eval": ("eval", "EvalManifest"),
    "renderer": ("renderer", "RendererManifestDocument"),
    "denoiser": ("denoiser", "DenoiserManifestDocument"),
}


def json_schema(name: str) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of the format ``name`` (a key of :data:`FORMATS`)."""
    from bnerr.errors import UnknownNameError

    if name not in FORMATS:
        raise UnknownNameError(f"format: expected one of {', '.join(FORMATS)}, got {name!r}")
    module, model = FORMATS[name]
    cls = getattr(importlib.import_module(f"bnerr.schemas.{module}"), model)
    schema: dict[str, Any] = cls.model_json_schema()
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}
