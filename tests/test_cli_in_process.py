"""tests/_cli.py, the in-process ``bnerr`` the doc-page tests run their commands with: inside
:func:`~tests._cli.fresh_process` a command sees the folders' entry points and plug-in files as a
new process would; after it, the test process is as it was (registries, entry-point scans,
modules, ``sys.path``, working folder, thread count), so that one command's plug-ins do not leak
into the next command or the next test."""

import os
import sys

import torch

from tests._cli import bnerr_in_process, fresh_process

PLUGIN = '''
def halve(frame):
    """Half the noisy colour."""
    return frame.color / 2
'''


def _install(site):
    """``toy_plugins:halve`` as the installed denoiser ``halved`` (a dist-info, as pip leaves)."""
    info = site / "toy_plugins-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy_plugins\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[bnerr.denoisers]\nhalved = toy_plugins:halve\n")


def test_a_command_sees_the_folders_plugins_and_leaves_nothing_behind(tmp_path):
    import denoisers

    (tmp_path / "toy_plugins.py").write_text(PLUGIN)
    _install(tmp_path / "site")
    before = (list(sys.path), os.getcwd(), torch.get_num_threads(), dict(denoisers.DENOISERS))
    with fresh_process(tmp_path, [tmp_path, tmp_path / "site"]):
        assert os.getcwd() == str(tmp_path)
        assert "halved" in denoisers.DENOISERS  # the entry point, read again
        assert denoisers.load_denoiser("toy_plugins.py:halve") == "halve"
        torch.set_num_threads(1)
    assert "halved" not in denoisers.DENOISERS and "halve" not in denoisers.DENOISERS
    assert not [name for name in sys.modules if "toy_plugins" in name]
    after = (list(sys.path), os.getcwd(), torch.get_num_threads(), dict(denoisers.DENOISERS))
    assert after == before


def test_the_exit_status_and_output_are_the_processs(tmp_path, capsys):
    code, out, err = bnerr_in_process("bnerr scenes", capsys, tmp_path)
    assert code == 0 and "direct" in out and not err
    code, out, err = bnerr_in_process("bnerr render --scene nowhere", capsys, tmp_path)
    assert code == 2 and not out and err.startswith("bnerr render: error: ")
    code, out, _ = bnerr_in_process("bnerr --help", capsys, tmp_path)  # argparse's SystemExit
    assert code == 0 and out.startswith("usage: bnerr")
