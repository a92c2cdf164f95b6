"""benchmarks.sweep.plugins: what ``--report-only`` says of the plug-ins a folder's records were
measured with (issue 54, item 10): a spec it cannot load and, now, an installed entry point that
this environment lacks (it was silent about those), each one line."""

from __future__ import annotations

import dataclasses

from benchmarks.sweep.plugins import load_recorded
from tests._records import metric_pairs, small_record


def _record(plugins: dict):
    pairs = metric_pairs([[1.0, 2.0]])
    record = small_record("white", "gaussian", raw={"mse": pairs}, den={"mse": pairs},
                          frames=2, seed_sets=1)  # fmt: skip
    return dataclasses.replace(record, plugins=plugins)


def test_report_only_names_a_missing_entry_point_and_a_missing_spec(tmp_path):
    records = [
        _record(
            {
                "bnerr.denoisers:gone_den": {
                    "spec": "entry point gone_den",
                    "fingerprint": "gonedist==1.2",
                },
                "bnerr.metrics:gone_metric": {
                    "spec": f"{tmp_path / 'gone.py'}:metric",
                    "fingerprint": "sha256:0",
                },
            }
        )
    ]
    notes = load_recorded(records)
    assert len(notes) == 2 and all("\n" not in n for n in notes)
    entry = next(n for n in notes if "gone_den" in n)
    assert "entry point gone_den of group bnerr.denoisers" in entry
    assert "gonedist==1.2" in entry and "reported from its records" in entry
    assert any("gone.py:metric" in n for n in notes)


def test_a_shipped_or_present_plug_in_gives_no_note():
    assert load_recorded([_record({})]) == []


def test_resume_refuses_a_changed_scene_file_or_denoiser_manifest(tmp_path, forget):
    """docs/PLUGINS.md, section 7 (issue 54: no test read it for files): a record measured with
    a scene file or an executable denoiser's manifest is refused by ``--resume`` once that file
    (or the manifest's program) changed; unchanged, it resumes."""
    import shutil

    import pytest

    import denoisers
    import renderers
    from benchmarks.sweep.plugins import check_resume, with_plugins
    from bnerr.errors import PluginError
    from tests._paths import EXAMPLES

    scene_file = tmp_path / "my_direct.toml"
    text = (EXAMPLES / "scenes" / "direct.toml").read_text()
    scene_file.write_text(text.replace('name = "direct"', 'name = "resume_direct"'))
    folder = tmp_path / "ext"
    shutil.copytree(EXAMPLES / "external_denoiser", folder)
    forget += [("bnerr.scenes", "resume_direct"), ("bnerr.denoisers", "example_joint_bilateral")]
    scene = renderers.load_scene(str(scene_file))
    denoiser = denoisers.load_denoiser(str(folder / "manifest.toml"))
    pairs = metric_pairs([[1.0, 2.0]])
    record = with_plugins(
        small_record(
            "white",
            denoiser,
            raw={"mse": pairs},
            den={"mse": pairs},
            frames=2,
            seed_sets=1,
            scene=scene,
        )
    )
    assert set(record.plugins) == {f"bnerr.scenes:{scene}", f"bnerr.denoisers:{denoiser}"}
    check_resume([record])  # unchanged: resumes
    for path in (scene_file, folder / "manifest.toml", folder / "denoise.py"):
        before = path.read_bytes()
        path.write_bytes(before + b"\n# changed\n")
        with pytest.raises(PluginError, match=r"--resume: expected plug-in .* unchanged"):
            check_resume([record])
        path.write_bytes(before)
    check_resume([record])
