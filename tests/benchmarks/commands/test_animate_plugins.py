"""``bnerr animate`` with plug-ins on its command line, in a subprocess: a scene file, a strategy
from ``file.py:Name`` beside white, and a denoiser function from ``file.py:name``."""

import re
import textwrap

from denoisers.tuning import ParamStore
from tests._paths import EXAMPLES, bnerr_cli

STRATEGY = """
from bnerr.strategies import WhiteStrategy


class Mine(WhiteStrategy):
    name = "mine"
    family = "experimental"
    stream = 0x51A7E0FF
"""

BOX = '''
import torch.nn.functional as F


def box(frame):
    """A 3x3 box filter."""
    return F.avg_pool2d(frame.color[None], 3, 1, 1, count_include_pad=False)[0]
'''


def test_animate_takes_a_scene_file_a_strategy_file_and_a_denoiser_file(tmp_path):
    (tmp_path / "strat.py").write_text(textwrap.dedent(STRATEGY))
    (tmp_path / "den.py").write_text(textwrap.dedent(BOX))
    scene = (EXAMPLES / "scenes" / "direct.toml").read_text()
    (tmp_path / "mine.toml").write_text(scene.replace('name = "direct"', 'name = "mine_scene"'))
    ParamStore().save(tmp_path / "tuned_params.json")  # no entries: the denoiser's defaults
    done = bnerr_cli(
        "animate", "--scene", str(tmp_path / "mine.toml"),
        "--strategies", "white", f"{tmp_path / 'strat.py'}:Mine",
        "--denoiser", f"{tmp_path / 'den.py'}:box", "--params", str(tmp_path),
        "--frames", "2", "--warmup", "0", "--res", "16x16", "--spp", "1",
        "--reference-spp", "4", "--gif-crop", "8", "--gif-frames", "2",
        "--cache", str(tmp_path / "cache"), "--out", str(tmp_path / "anim"),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert re.search(r"\bmine \d", done.stdout)  # the plug-in strategy's column was rendered
    names = sorted(p.name for p in (tmp_path / "anim").iterdir() if not p.name.startswith("."))
    assert names == ["README.md", "mine_scene.gif", "mine_scene.mp4"]
    readme = (tmp_path / "anim" / "README.md").read_text()
    assert "--strategies white mine --denoiser box" in readme
