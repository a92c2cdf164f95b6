"""The model of a frame folder's ``manifest.toml``, what ``bnerr eval`` reads (docs/EVAL.md;
:mod:`benchmarks.commands.eval.frame_folder` reads the folder).

It says what the folder's layout cannot: the scene, the resolution, the method and seed-set
folders, how many frames, which auxiliary buffers each frame holds and which pixel regions to
measure. Every folder name must be one plain path component (no ``/``, ``..``, absolute, hidden
or control characters), a method ``white`` (the baseline) must be among the methods, and a region
must have the buffers it is computed from. An unknown key, buffer or region is an
:class:`~bnerr.errors.UnknownNameError`, every other problem a
:class:`~bnerr.errors.ValueRangeError`.
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

from pydantic import AfterValidator, Field, model_validator

from bnerr.frame import BUFFERS
from bnerr.metrics.regions import REGION_BUFFERS
from bnerr.schemas.fields import Check, Table, problem

__all__ = ["AUX_BUFFERS", "MAX_PIXELS", "RESERVED", "EvalManifest"]

#: The auxiliary buffers a frame may carry, and their channel counts.
AUX_BUFFERS: dict[str, int] = {**{k: v for k, v in BUFFERS.items() if k != "color"}, "variance": 3}
#: The largest frame the manifest may declare (``width * height``): 64 megapixels.
MAX_PIXELS = 1 << 26
#: Folder names a method may not take: the references', and ``bnerr eval``'s default output.
RESERVED = ("reference", "results")
_REGIONS = {k: v for k, v in REGION_BUFFERS.items() if k in ("all", "edges", "coherent")}
_RANGE, _UNKNOWN = "ValueRangeError", "UnknownNameError"


def _refuse(what: str, value: object, error: str = _RANGE) -> Exception:
    """The format's problem: ``expected {what}, got {value!r}`` (its messages quote the value
    as written, without its type)."""
    return problem(f"expected {what}, got {value!r}", error=error)


def _integer(minimum: int) -> Check:
    def check(value: object) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise _refuse(f"an integer >= {minimum}", value)
        return value

    return Check(check, minimum=minimum)


def _text(value: object) -> str:
    if not isinstance(value, str) or not value:
        raise _refuse("a non-empty string", value)
    return value


def _flag(value: object) -> bool:
    if not isinstance(value, bool):
        raise _refuse("true or false", value)
    return value


def _folder(value: object) -> str:
    """A folder name: one plain path component (no separator, not ``.``/``..``, not hidden)."""
    if (
        not isinstance(value, str)
        or not value
        or value.startswith(".")
        or "/" in value
        or "\\" in value
        or value != value.strip()
        or not value.isprintable()
    ):
        raise _refuse(
            "plain folder names inside the folder (no '/', '..', absolute, hidden names or "
            "control characters)",
            value,
        )
    return value


def _names(empty: bool = False, known: tuple[str, ...] = ()) -> Check:
    """A list of distinct folder names (``known``: the only names allowed); empty if ``empty``."""

    def check(value: object) -> tuple[str, ...]:
        if not isinstance(value, list) or not (value or empty):
            raise _refuse("a non-empty list of names", value)
        names = tuple(_folder(v) for v in value)
        for name in names:
            if known and name not in known:
                raise problem(
                    f"expected names from {', '.join(known)}, got {name!r}", error=_UNKNOWN
                )
        if len(set(names)) != len(names):
            raise _refuse("distinct names", list(names))
        return names

    schema: dict[str, Any] = {"uniqueItems": True, "minItems": 0 if empty else 1}
    return Check(check, **schema, **({"items": {"enum": list(known)}} if known else {}))


def _resolution(value: object) -> tuple[int, int]:
    if not (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in value)
    ):
        raise _refuse("[width, height]", value)
    if value[0] * value[1] > MAX_PIXELS:
        raise problem(f"expected at most {MAX_PIXELS} pixels, got {value[0]} x {value[1]}")
    return value[0], value[1]


def _methods(names: tuple[str, ...]) -> tuple[str, ...]:
    if "white" not in names:
        raise _refuse(
            "the white baseline (a method named 'white'; every ratio is to it)", list(names)
        )
    reserved = [m for m in names if m in RESERVED]
    if reserved:
        raise problem(
            f"expected names other than {', '.join(RESERVED)} (reserved), got {', '.join(reserved)}"
        )
    return names


Names = Annotated[tuple[str, ...], _names()]
Count = Annotated[int, _integer(0)]


class EvalManifest(Table):
    """A frame folder's ``manifest.toml``: what its layout cannot say (docs/EVAL.md)."""

    whole_file: ClassVar[bool] = True

    scene: Annotated[str, Check(_text)] = Field(description="the scene's name (tables and pages)")
    spp: Annotated[int, _integer(1)] = Field(description="samples per pixel of the noisy frames")
    resolution: Annotated[tuple[int, int], Check(_resolution)] = Field(
        description="[width, height] of every frame"
    )
    methods: Annotated[Names, AfterValidator(_methods)] = Field(
        description="the method folders, white (the baseline) among them"
    )
    seed_sets: Names = Field(description="the seed-set folder names, the same under every method")
    frames: Annotated[int, _integer(1)] = Field(description="measured frames per seed set")
    warmup: Count = Field(0, description="frames before the measured ones (default 0)")
    buffers: Annotated[tuple[str, ...], _names(True, tuple(AUX_BUFFERS))] = Field(
        (), description="auxiliary buffers of every frame (default none)"
    )
    regions: Annotated[tuple[str, ...], _names(False, tuple(_REGIONS))] = Field(
        None,  # type: ignore[arg-type]
        description="pixel regions (default all, plus coherent where the buffers allow)",
    )
    static: Annotated[bool, Check(_flag)] = Field(
        False, description="true: one reference, reference/0000.exr, serves every frame"
    )
    reference_spp: Count = Field(
        0, description="samples per pixel of the references (default 0: unknown)"
    )
    sampler: Annotated[str, Check(_text)] = Field(
        "owen_sobol", description="the per-pixel sampler, a label (default owen_sobol)"
    )
    dimensions: Count = Field(
        0, description="sampler dimensions one path uses (default 0: unknown)"
    )
    tuning_seed_set: Annotated[str, Check(_folder)] = Field(  # type: ignore[assignment]
        None, description="a held-out seed-set folder the denoisers are tuned on"
    )

    @classmethod
    def check_keys(cls, data: dict) -> None:
        """Every unknown key at once (an UnknownNameError), then every missing required one."""
        unknown = sorted(set(data) - set(cls.model_fields))
        if unknown:
            known = ", ".join(cls.model_fields)
            message = f"unknown keys {', '.join(unknown)}; expected keys from {known}"
            raise problem(message, error=_UNKNOWN)
        missing = [k for k, f in cls.model_fields.items() if f.is_required() and k not in data]
        if missing:
            raise problem(f"expected the keys {', '.join(missing)}, got none")

    @model_validator(mode="after")
    def _agree(self) -> EvalManifest:
        """The tuning seed set apart from the measured ones; each region's buffers present, and
        ``coherent``'s reference of the frame before the first measured one."""
        if self.tuning_seed_set is not None and self.tuning_seed_set in self.seed_sets:
            raise problem(
                f"expected a folder apart from the measured seed sets {list(self.seed_sets)}, got "
                f"{self.tuning_seed_set!r}",
                at="tuning_seed_set",
            )
        if "coherent" in (self.regions or ()) and not (self.static or self.warmup >= 1):
            raise problem(
                "expected warmup >= 1 or static = true (its disocclusion test reads the reference "
                "of the frame before the first measured one), got warmup 0",
                at="region 'coherent'",
            )
        for region in self.regions or ():
            missing = [b for b in _REGIONS[region] if b not in self.buffers]
            if missing:
                raise problem(
                    f"expected buffers {', '.join(missing)} in buffers, got {list(self.buffers)}",
                    at=f"region {region!r}",
                )
        return self
