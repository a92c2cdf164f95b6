"""The model of a renderer manifest: a renderer run as a program per frame through the seed
protocol (:mod:`renderers.external`; docs/RENDERER_PROTOCOL.md).

Besides the keys of every program manifest (:mod:`bnerr.schemas.manifest`), it says which
buffers each frame holds (``color`` among them), which per-pixel samplers the program implements,
how many sampler dimensions one path takes, and whether one run renders all K candidate frames.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import AfterValidator, Field, model_validator

from bnerr.schemas.fields import Boolean, Check, problem
from bnerr.schemas.manifest import (
    FRAME_BUFFERS,
    Command,
    Name,
    ProgramManifest,
    Seconds,
    Text,
    distinct,
    expect,
)

__all__ = ["SAMPLERS", "RendererManifestDocument"]

#: The samplers the protocol can describe to a renderer (``{sampler}``).
SAMPLERS: tuple[str, ...] = ("owen_sobol", "ldbn")
_NAMES = expect("a list of names", list)


def _with_color(buffers: tuple[str, ...]) -> tuple[str, ...]:
    if "color" not in buffers:
        raise problem(f"expected 'color' among them, got {buffers}")
    return buffers


class RendererManifestDocument(ProgramManifest):
    """A renderer manifest (docs/RENDERER_PROTOCOL.md)."""

    whole_file: ClassVar[bool] = True

    name: Name = Field(description="the scene's name in the records and the reference cache")
    command: Command = Field(description="argv with {placeholders}, run in the manifest's folder")

    buffers: Annotated[
        tuple[str, ...], AfterValidator(_with_color), distinct(FRAME_BUFFERS), _NAMES
    ] = Field(("color",), description="buffers each frame must hold, color among them")
    samplers: Annotated[tuple[str, ...], distinct(SAMPLERS), _NAMES] = Field(
        ("owen_sobol",), description="the per-pixel samplers the program implements"
    )
    dimensions: Annotated[int, Check(lambda v: v, minimum=1), expect("an integer", int)] = Field(
        8, description="sampler dimensions one path takes (the scene's D)"
    )
    timeout_s: Seconds = Field(300.0, description="seconds per run; the program is then killed")
    batch: Boolean = Field(
        False, description="true: one run per seed file of K images ({out}: a folder)"
    )
    description: Text = Field("", description="free text")

    @model_validator(mode="after")
    def _dimensions(self) -> RendererManifestDocument:
        if self.dimensions < 1:
            raise problem(
                f"expected dimensions >= 1 and timeout_s > 0, got {self.dimensions} and "
                f"{self.timeout_s}"
            )
        return self
