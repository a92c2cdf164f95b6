"""The camera sidecar's model: ``scene.camera.toml`` beside a Mitsuba XML scene
(:func:`renderers.scene_file.load_camera_path`, :mod:`renderers.mitsuba_scene`).

Its keys are a scene file's ``[camera]`` without the optics: ``origin`` and ``target`` are
motions (a bare ``[x, y, z]`` or a fixed, linear or orbit table) and ``up`` a vector. That the
pose stays valid over the frames is checked where the motions are built.
"""

from __future__ import annotations

from typing import ClassVar

from bnerr.schemas.fields import Table
from bnerr.schemas.scene import Direction, Motion

__all__ = ["CameraPath"]


class CameraPath(Table):
    """A camera path: where the camera is and looks at each frame, and which way is up."""

    whole_file: ClassVar[bool] = True

    origin: Motion
    target: Motion
    up: Direction = (0.0, 1.0, 0.0)
