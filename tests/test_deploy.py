"""`scdp deploy`: the whole camera -> plan -> 1 kHz path on the tiny preset's Block Reach checkpoints."""

import dataclasses
import json

import cv2
import numpy as np
import pytest

from scdp.cli import main
from scdp.content import file_sha256
from scdp.deploy import SCENE_KEYS, polyline_distance
from scdp.deploy.media import PATH_RGB
from scdp.tasks import BLOCK_REACH


@pytest.fixture
def short_episodes(monkeypatch):
    """20 control steps instead of 250: the untrained tiny planner never reaches a block, and every step is
    100 ticks of the 1 kHz arm (and 5 video frames); the record, strip and video are the same with fewer of them."""
    short = dataclasses.replace(BLOCK_REACH, max_episode_steps=20)
    monkeypatch.setattr("scdp.cli.deploy.get_task", lambda name: short)


def test_deploy_writes_a_full_record_strip_and_video(tiny_reproduction, tmp_path, capsys, short_episodes):
    out = tmp_path / "deployed"
    ckpt = tiny_reproduction / "block_reach" / "checkpoints"
    assert main(["deploy", "--task", "block_reach", "--checkpoints", str(ckpt), "--scene-seed", "4", "--out", str(out)]) == 0
    record = json.loads((out / "deploy.json").read_text())
    assert set(SCENE_KEYS) <= set(record)
    assert set(record["parts"]) == {"base", "encoder", "style_legible", "style_efficient"}  # scdp's, by default
    assert record["parts"]["base"] == {"weights_sha256": file_sha256(ckpt / "base" / "model.safetensors"), "runtime": "torch"}
    assert max(record["localisation_error_m"]) < 0.005  # detection in the loop found both blocks
    assert record["limit_violations"] == [] and record["limit_ratios"]["jerk"] <= 1.0
    assert len(record["styles"]) == len(record["planning_s_per_chunk"]) >= 1
    assert record["tracking_error"]["tcp_m"] < 0.005
    assert record["duration_s"] >= record["schedule_s"] - 1e-9  # never faster than the 10 Hz schedule
    strip = cv2.imread(str(out / "strip.png"))
    assert strip is not None and strip.shape[1] > 2 * strip.shape[0]  # frames side by side
    traced = np.all(np.abs(strip[..., ::-1].astype(int) - PATH_RGB) < 40, axis=-1)  # BGR on disk
    assert traced[:, strip.shape[1] // 2:].sum() > 20  # the TCP's path is drawn on the later frames
    assert cv2.imread(str(out / "detections.png")) is not None  # the detection camera's frame, beside them
    assert record["arm_drawn"].startswith("Panda drawn with Franka's meshes (gymnasium-robotics")  # the test extra has them
    band = strip[-strip.shape[0] // 20:]  # the caption band under the frames: white, with dark words
    assert (band > 230).mean() > 0.8 and (band < 120).any()
    assert cv2.VideoCapture(str(out / "deploy.mp4")).get(cv2.CAP_PROP_FRAME_COUNT) > 5
    capsys.readouterr()
    # an existing output is kept unless --force
    assert main(["deploy", "--checkpoints", str(ckpt), "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err


def test_deploy_many_scenes_summarises_them(tiny_reproduction, tmp_path, short_episodes):
    out = tmp_path / "many"
    ckpt = tiny_reproduction / "block_reach" / "checkpoints"
    assert main(["deploy", "--checkpoints", str(ckpt), "--scenes", "2", "--method", "dp", "--depth-noise", "--no-video",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    scenes = sorted((out / "scenes").glob("seed_*.json"))
    assert summary["scenes"] == 2 and len(scenes) == 2 and summary["depth_noise"] is True
    successes = [json.loads(p.read_text())["success"] for p in scenes]
    assert summary["success_rate"] == sum(successes) / 2
    assert not (out / "strip.png").exists()


def test_polyline_distance():
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    points = np.array([[0.5, 0.2, 0], [1.3, 0.5, 0], [2, 2, 0], [0.5, 0, 0]])
    assert np.allclose(polyline_distance(points, vertices), [0.2, 0.3, np.sqrt(2), 0.0])
