"""`scdp verify`: a run's own verdicts on fresh scenes, beside the committed run's (the tiny run stands
for both; its untrained planners make verdicts that may go either way, which is all this needs)."""

import json
import shutil

from scdp.cli import main


def _verify(capsys, *args) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(["verify", *args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_every_committed_verdict_is_set_beside_the_runs_own(tiny_reproduction, tmp_path, capsys):
    against = tmp_path / "committed"
    shutil.copytree(tiny_reproduction, against, ignore=shutil.ignore_patterns("navigation", "block_reach"))
    judged = json.loads((against / "claims.json").read_text())
    first = next(c for c in judged["claims"] if c["task"] == "navigation" and c.get("protocol", "random") == "random")
    first["holds"] = not first["holds"]  # a committed verdict this run cannot share with the original
    (against / "claims.json").write_text(json.dumps(judged))
    code, out, _ = _verify(capsys, str(tiny_reproduction), "--against", str(against), "--scenes", "2", "--out", str(tmp_path / "v.json"))
    assert code == 0
    report = json.loads((tmp_path / "v.json").read_text())
    committed = [r for r in judged["claims"] + judged["targets"] + judged["observer_targets"]
                 if r.get("protocol", "random") == "random" and "layouts_" not in r.get("claim", "")]
    assert judged["observer_targets"]  # the observer targets are among the verdicts compared
    scene = [r for r in report["rows"] if r["normalisation"] == "scene"]
    assert len(scene) == len(committed) and report["tasks"] == ["navigation", "block_reach"]
    assert report["total"] == len(report["rows"]) == 2 * len(committed)  # and each again over the training data
    assert all(r["run"] in (True, False) for r in report["rows"])
    flipped = next(r for r in scene if (r["task"], r["verdict"]) == ("navigation", first["claim"]))
    assert flipped["committed"] == first["holds"]
    line = next(x for x in out.splitlines() if x.startswith(f"| navigation | scene | {first['claim']} |"))
    assert ("(differs)" in line) == (flipped["run"] != flipped["committed"])
    assert f"{report['agree']} of {report['total']} verdicts agree" in out


def test_a_folder_without_checkpoints_is_refused_in_one_line(tiny_reproduction, tmp_path, capsys):
    code, _, err = _verify(capsys, str(tmp_path), "--against", str(tiny_reproduction))
    assert code == 2 and err.startswith("scdp: error: run: ") and err.count("\n") == 1
    code, _, err = _verify(capsys, str(tiny_reproduction), "--against", str(tmp_path))
    assert code == 2 and err.startswith("scdp: error: --against: ")
