"""Tests of scdp.study.record: study.json read as typed records, a malformed one refused naming its field."""

import json

import pytest

from helpers.studies import synthetic_study
from scdp.cli import main
from scdp.study.record import MAIN, Study


def test_a_study_round_trips_through_its_record(tmp_path):
    synthetic_study(tmp_path / "s", camera=True, fps=5)
    written = json.loads((tmp_path / "s" / "study.json").read_text())
    study = Study.from_dict(written)
    assert study.config.methods == ("dp", "scdp") and study.config.screening.max_lag == 0.15
    stim = study.stimuli[study.ids(MAIN)[0]]
    assert stim.view.kind == "camera" and len(stim.view.frames) == 6 and stim.target in (0, 1)  # 0, 0.2, ... 1.0 s
    again = study.to_dict()
    assert again["stimuli"] == written["stimuli"] and again["config"] == written["config"]


@pytest.mark.parametrize("damage, field", [
    (lambda s: s["stimuli"][next(iter(s["stimuli"]))].pop("target"), "target: missing"),
    (lambda s: s["stimuli"][next(iter(s["stimuli"]))].update(target=7), "target 7 do not fit"),
    (lambda s: s["stimuli"][next(iter(s["stimuli"]))].update(target="1"), "target: must be int, got str"),
    (lambda s: s["stimuli"][next(iter(s["stimuli"]))]["view"].update(kind="video"), "view.kind: must be one of"),
    (lambda s: s["config"].update(fps=500), "config.fps: must be from 5 to 30"),
    (lambda s: s["config"].update(speed=2), "config: "),
    (lambda s: s.update(format=1), "is of format 1"),
    (lambda s: s.update(format=3), "scdp at commit 40bad6e (the last to read it) serves and analyses it"),
    (lambda s: s.update(format=5), "scdp at commit 6fbd00d"),
    (lambda s: s.pop("success_radius"), "success_radius: missing"),
    (lambda s: s.update(success_radius=-0.1), "success_radius: must be a positive number of metres"),
])
def test_a_damaged_study_is_refused_in_one_line_naming_the_field(tmp_path, capsys, damage, field):
    synthetic_study(tmp_path / "s")
    path = tmp_path / "s" / "study.json"
    record = json.loads(path.read_text())
    damage(record)
    path.write_text(json.dumps(record))
    assert main(["study", "analyze", "--study", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("scdp: error: ") and field in err[0]
    assert not (tmp_path / "s" / "analysis").exists()  # nothing written
