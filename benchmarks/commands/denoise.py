"""``bnerr denoise``: denoise one frame file (as ``bnerr render`` writes it) with a named denoiser.

    bnerr denoise --denoiser gaussian --in frame.exr --out out.exr --params sigma=1.5
    bnerr denoise --denoiser atrous --in frame.exr --out out.exr --tuned params.json --scene cornell

``--denoiser`` takes a plug-in too (:mod:`bnerr.plugins`): a spec ``pkg.mod:attr`` or
``path/to/file.py:Name``, or an executable denoiser's manifest (``.toml``, ``.json``).

``--scene`` takes a key of the tuned-parameters file (``cornell/m1/owen_sobol/128x128``) or just
the scene's name when the file holds one key for it; ``--spp`` may be left out when that key has
one spp. Otherwise the error lists the candidates.

``--out`` names the format (:func:`bnerr.io.image_format`): ``.exr`` writes the input frame with
its color replaced by the denoised color (the auxiliary buffers are kept, so the file reads back
as a Frame) and ``timings["denoise"]`` in milliseconds; ``.png`` writes a tone-mapped preview of
the denoised color (``--exposure``); any other suffix is refused before any work.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from benchmarks.commands._args import EXPOSURE, positive_int
from bnerr.errors import DtypeError, check_device
from bnerr.frame import Frame
from bnerr.io import image_format, read_frame, write_image
from bnerr.outputs import check_output
from bnerr.timing import sync
from denoisers import denoiser_identity, get_denoiser, load_denoiser
from denoisers.tuning import ParamStore

__all__ = ["parse_params", "register", "run"]


def parse_params(items: list[str]) -> dict[str, object]:
    """``["sigma=1.5", "kernel_size=3", "weights=w.pt"]`` -> ``{"sigma": 1.5, ...}``.

    A value is read as JSON when it parses (numbers, true/false), else kept as a string.
    """
    params: dict[str, object] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise DtypeError(f"--params: expected KEY=VALUE, got {item!r}")
        try:
            params[key] = json.loads(value)
        except json.JSONDecodeError:
            params[key] = value
    return params


def _params(args: argparse.Namespace) -> dict[str, object]:
    """``--params``, over the ``--tuned`` entry of ``--scene`` (and ``--spp``) when given."""

    params = parse_params(args.params)
    if args.tuned is None:
        return params
    if args.scene is None:
        raise DtypeError("--tuned: expected --scene with it, got no --scene")
    store = ParamStore.load(args.tuned)
    key, spp = store.resolve(args.denoiser, args.scene, args.spp)
    return {**store.params(args.denoiser, key, spp), **params}


def run(args: argparse.Namespace) -> int:

    image_format(args.output, "--out")  # before anything: the name decides the format
    source = Path(args.input)
    # The output is about as large as the input (same buffers, new color): check the folder
    # before reading anything.
    need = source.stat().st_size if source.is_file() else 0
    output = check_output(args.output, "file", need_bytes=need)
    if output.resolve() == source.resolve():
        raise DtypeError(f"--out {output}: expected a file other than --in, got the same file")
    device = check_device(args.device, "--device")
    args.denoiser = load_denoiser(args.denoiser)  # a plug-in: its registered name (for --tuned)
    denoiser = get_denoiser(args.denoiser, **_params(args))
    frame = read_frame(source)
    given = frame if device.type == "cpu" else frame.to(device)
    start = time.perf_counter()
    color = denoiser(given)  # checks every buffer it reads, and its output, for NaN
    sync(color)  # a GPU's queued work counts
    elapsed_ms = 1000.0 * (time.perf_counter() - start)
    color = color.cpu()
    buffers = {**frame.buffers(), "color": color}
    timings = {**frame.timings, "denoise": elapsed_ms}
    write_image(output, Frame(**buffers, timings=timings, own_denoised={}), exposure=args.exposure)
    kind = denoiser_identity(args.denoiser).kind  # filter, temporal, learned, a plug-in's own
    size = f"{frame.width}x{frame.height}"
    print(f"{denoiser!r} ({kind}): {size} in {elapsed_ms:.1f} ms -> {args.output}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "denoise",
        help="denoise a frame file with a named denoiser",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument(
        "--denoiser",
        required=True,
        help="a registered denoiser (denoisers.DENOISERS: gaussian, atrous, unet, oidn, ...) or a "
        "plug-in (pkg.mod:attr, path/file.py:Name, an executable's manifest .toml/.json); a "
        "temporal one (taa, svgf) sees the frame as the first of its sequence",
    )
    p.add_argument(
        "--in", dest="input", required=True, metavar="FRAME.exr", help="frame from bnerr render"
    )
    p.add_argument(
        "--out",
        dest="output",
        required=True,
        metavar="OUT.exr|OUT.png",
        help="where to write the result: .exr (every buffer, exact) or .png (tone-mapped preview)",
    )
    p.add_argument(
        "--exposure", type=EXPOSURE, default=0.0, help="exposure in stops of a .png output"
    )
    p.add_argument(
        "--params", nargs="*", default=[], metavar="KEY=VALUE", help="denoiser parameters"
    )
    p.add_argument(
        "--tuned", metavar="PARAMS.json", help="take parameters from a tuned-parameters file"
    )
    p.add_argument(
        "--device", default="cpu", help="torch device to denoise on: cpu (default), cuda, cuda:N"
    )
    p.add_argument(
        "--scene",
        help="scene key to look up in --tuned (direct/m1/owen_sobol/128x128), or the scene's name "
        "alone (direct) when the file holds one key for it",
    )
    p.add_argument(
        "--spp", type=positive_int, help="spp to look up in --tuned (optional when it holds one)"
    )
    p.set_defaults(func=run)
