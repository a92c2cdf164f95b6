"""benchmarks.sweep.external_renderer: the sweep's parts and suite with a renderer program driven
through the seed protocol (a Python stand-in here; the C example runs in
tests/benchmarks/commands/test_bench_renderer.py)."""

from __future__ import annotations

import dataclasses
import sys

import pytest
import torch

from benchmarks.suites import Condition
from benchmarks.sweep.external_renderer import (
    ExternalScene,
    external_parts,
    renderer_regions,
    renderer_suite,
    strategy_sampler,
)
from benchmarks.sweep.parts import BoundRender, real_parts
from benchmarks.sweep.runner import run_suite
from bnerr.errors import UnknownNameError, ValueRangeError
from bnerr.metrics.regions import REGION_BUFFERS
from renderers.external import ExternalRenderer, command_manifest
from tests._suites import tiny_suite

pytestmark = pytest.mark.usefixtures("one_thread")

#: color = seed / 2^32 (a seed's error moves with it), albedo and object_id constant.
SCRIPT = """
import struct, sys
import numpy as np, OpenEXR
seeds, out = sys.argv[1:3]
data = open(seeds, 'rb').read()
_, _, w, h, k, _ = struct.unpack_from('<4s5I', data)
s = np.frombuffer(data, '<u4', offset=24).reshape(k, h, w)[0]
r = np.ascontiguousarray(0.5 + (s / 2**32 - 0.5) * 0.2, dtype=np.float32)
c = {'R': r, 'G': r, 'B': r, 'object_id.Y': np.zeros_like(r), 'depth.Z': np.ones_like(r)}
c.update({f'albedo.{x}': np.ones_like(r) for x in 'RGB'})
c.update({f'normal.{x}': np.ones_like(r) * (x == 'Z') for x in 'XYZ'})
OpenEXR.File({'type': OpenEXR.scanlineimage}, c).write(out)
"""


@pytest.fixture
def renderer(tmp_path):
    (tmp_path / "flat.py").write_text(SCRIPT)
    template = f"{sys.executable} flat.py {{seeds}} {{out}} --spp {{spp}}"
    return ExternalRenderer(command_manifest(template, "flat", tmp_path))


def test_the_parts_render_the_programs_one_scene_and_key_its_references_by_it(renderer):
    parts = external_parts(renderer)
    scene = parts.get_scene("flat", True)
    assert scene == ExternalScene("flat", 8)
    with pytest.raises(UnknownNameError, match="expected the external renderer's 'flat'"):
        parts.get_scene("direct", False)
    with pytest.raises(ValueRangeError, match="expected no depth condition"):
        parts.with_depth(scene, 2)
    assert parts.code_version.startswith(real_parts().code_version + "+flat-")
    strategy = parts.make_strategy("oracle", scene, 6, 5, 0, "owen_sobol", 1)
    frame = strategy.frame(0, BoundRender(parts, scene, 1))
    assert frame.color.shape == (3, 6, 5) and frame.timings["render"] > 0


def test_the_suite_keeps_the_strategies_whose_sampler_the_program_lists(renderer):
    suite = tiny_suite(strategies=("white", "temporal", "oracle", "ldbn", "bnds"))
    kept, dropped = renderer_suite(suite, renderer, named=False)
    assert kept.sweeps[0].strategies == ("white", "temporal", "oracle")
    assert kept.sweeps[0].scenes == ("flat",) and dropped == ("ldbn", "bnds")
    with pytest.raises(ValueRangeError, match="--strategies ldbn: expected a strategy whose"):
        renderer_suite(suite, renderer, named=True)
    white = tiny_suite(conditions=(Condition(sampler="white"),))
    with pytest.raises(ValueRangeError, match="expected to render the white baseline"):
        renderer_suite(white, renderer, named=False)
    assert strategy_sampler("temporal+relative", "owen_sobol") == "owen_sobol"
    assert strategy_sampler("ldbn_fast", "owen_sobol") == "ldbn"


def test_regions_need_the_buffers_the_manifest_lists(tmp_path):
    """Issue 54: a renderer giving colour only (the default ``buffers = ["color"]``) stopped the
    default bench after 7 frames ("expected an object_id buffer for region 'coherent'"): the
    regions it cannot give are left out before the first render, the others kept."""
    (tmp_path / "flat.py").write_text(SCRIPT)
    color = ExternalRenderer(
        command_manifest(f"{sys.executable} flat.py {{seeds}} {{out}} {{spp}}", "flat", tmp_path)
    )
    assert color.manifest.buffers == ("color",)
    regions = (Condition(region="all"), Condition(region="edges"), Condition(region="unlit"))
    suite = dataclasses.replace(tiny_suite(conditions=regions), coherent=True)
    kept, dropped = renderer_regions(suite, color)
    assert [c.region for c in kept.sweeps[0].conditions] == ["all"] and not kept.coherent
    assert dropped == ("edges", "unlit", "coherent")
    full = ExternalRenderer(
        dataclasses.replace(color.manifest, buffers=("color", *REGION_BUFFERS["coherent"]))
    )
    assert renderer_regions(suite, full) == (suite, ())
    edges = tiny_suite(conditions=(Condition(region="edges"),))
    with pytest.raises(ValueRangeError, match=r"expected the buffers object_id for the regions"):
        renderer_regions(edges, color)


@pytest.mark.slow
def test_the_runner_measures_the_programs_frames_against_its_own_reference(renderer, tmp_path):
    suite, _ = renderer_suite(tiny_suite(res=(8, 8), denoisers=("gaussian",)), renderer, False)
    parts = external_parts(renderer)
    cache = tmp_path / "cache"  # not the default cache/references of the checkout
    records = run_suite(suite, tmp_path / "out", parts=parts, cache_dir=cache, progress=False)
    assert {r.cell.scene for r in records} == {"flat"}
    white = next(r for r in records if r.cell.strategy == "white" and r.cell.region == "all")
    assert all(ms > 0 for frames in white.timings.render_ms for ms in frames)
    assert torch.tensor(white.raw["mse"]).gt(0).all()


#: A stand-in that logs, per run, its argument list and what it read from stdin (then a frame
#: of its seeds, as SCRIPT): the protocol's run-time claims read off its log.
LOGGING = """
import json, os, signal, struct, sys
import numpy as np, OpenEXR
signal.signal(signal.SIGALRM, lambda *a: (_ for _ in ()).throw(TimeoutError()))
signal.alarm(5)
try:
    stdin = "eof" if os.read(0, 1) == b"" else "data"
except OSError:
    stdin = "closed"
except TimeoutError:
    stdin = "blocked"
signal.alarm(0)
log, seeds, out = sys.argv[1:4]
with open(log, "a") as f:
    f.write(json.dumps({"argv": sys.argv[4:], "stdin": stdin}) + "\\n")
data = open(seeds, 'rb').read()
_, _, w, h, k, _ = struct.unpack_from('<4s5I', data)
s = np.frombuffer(data, '<u4', offset=24).reshape(k, h, w)[0]
r = np.ascontiguousarray(0.5 + (s / 2**32 - 0.5) * 0.2, dtype=np.float32)
OpenEXR.File({'type': OpenEXR.scanlineimage}, {'R': r, 'G': r, 'B': r}).write(out)
"""


def test_the_protocols_run_time_claims(tmp_path):
    """docs/RENDERER_PROTOCOL.md (issue 54: no test read these): ``{width}``, ``{height}`` and
    ``{{ }}`` are filled at run time, stdin is closed (a read ends at once), and the references
    are rendered at the reference spp (the other stand-ins ignore ``{spp}``)."""
    import json

    (tmp_path / "logging.py").write_text(LOGGING)
    log = tmp_path / "runs.jsonl"
    template = (
        f"{sys.executable} logging.py {log} {{seeds}} {{out}} --spp {{spp}} --size "
        "{width}x{height} {{literal}}"
    )
    renderer = ExternalRenderer(command_manifest(template, "logged", tmp_path))
    suite, _ = renderer_suite(
        tiny_suite(res=(10, 8), strategies=("white",), denoisers=("gaussian",), reference_spp=8,
                   frames=1, warmup=0, seed_sets=1),
        renderer, False,
    )  # fmt: skip
    run_suite(
        suite, tmp_path / "out", parts=external_parts(renderer), cache_dir=tmp_path / "cache",
        progress=False,
    )  # fmt: skip
    runs = [json.loads(line) for line in log.read_text().splitlines()]
    assert runs and all(r["stdin"] in ("eof", "closed") for r in runs), runs
    for r in runs:
        assert r["argv"][2:] == ["--size", "10x8", "{literal}"], r["argv"]
    spps = sorted(int(r["argv"][1]) for r in runs)
    assert spps[0] == 1 and spps[-1] == 8, spps  # the frames at 1 spp, the reference at 8
