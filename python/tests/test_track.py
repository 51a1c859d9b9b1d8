"""Tracking from Python: the CLI's tracker fed frame by frame gives faces.jsonl's faces, ids kept, the
detector on schedule; bad arguments raise ValueError."""

import json
import os
import subprocess

import numpy as np
import pytest

import facesynth
from png_files import read_png

CLI = os.environ["FACESYNTH_CLI"]


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    out = tmp_path_factory.mktemp("track") / "clip"
    subprocess.run([CLI, "synth", "-q", "-o", str(out), "-n", "20", "--sequence", "20", "--size", "256", "--seed", "3",
                    "--set", "pose.yaw.min=-20", "--set", "pose.yaw.max=20", "--set", "degrade.blur_probability=0"], check=True)
    return out


def test_tracker_gives_the_cli_faces_frame_by_frame(clip, tmp_path):
    tracked = tmp_path / "tracked"
    subprocess.run([CLI, "track", "-q", str(clip / "images"), "-o", str(tracked), "--detector", "dlib", "--detect-every", "5"], check=True)
    records = [json.loads(line) for line in open(tracked / "faces.jsonl")]
    assert len(records) == 20

    tracker = facesynth.Tracker(detector="dlib", detect_every=5)
    for record, frame in zip(records, sorted((clip / "images").iterdir())):
        faces = tracker.process(read_png(frame))
        assert len(faces) == len(record["faces"]) == 1, frame
        face, expected = faces[0], record["faces"][0]
        assert face["id"] == 0 and face["detected"] == (record["frame"] % 5 == 0)
        assert face["landmarks"].shape == (68, 2) and face["landmarks"].dtype == np.float64
        assert np.allclose(face["landmarks"], expected["landmarks"], atol=1e-9, rtol=0), frame
        assert face["box"] == pytest.approx(tuple(expected["box"]))
        for key in ("yaw", "pitch", "roll", "fit_error"):
            assert face[key] == pytest.approx(expected[key], abs=1e-9), key
        assert face["identity_frames"] == record["frame"] + 1
    assert tracker.counters == {"frames": 20, "detector_runs": 4, "fallback_detector_runs": 0, "losses": 0, "reacquired": 0,
                                "cuts": 0, "reidentified": 0}


def test_per_frame_baseline_detects_every_frame(clip):
    tracker = facesynth.Tracker(detector="dlib", track=False)
    frames = sorted((clip / "images").iterdir())[:4]
    for frame in frames:
        faces = tracker.process(read_png(frame))
        assert len(faces) == 1 and faces[0]["detected"]
    assert tracker.counters["detector_runs"] == len(frames)


def test_bad_arguments(clip, tmp_path):
    frame = read_png(sorted((clip / "images").iterdir())[0])
    tracker = facesynth.Tracker(detector="dlib")
    tracker.process(frame, time_s=1.0)
    with pytest.raises(ValueError, match="time_s"):
        tracker.process(frame, time_s=1.0)
    with pytest.raises(ValueError, match="time_s"):
        tracker.process(frame, time_s=float("nan"))
    with pytest.raises(ValueError, match="image"):
        tracker.process(np.zeros((8, 8, 5), np.uint8), time_s=2.0)
    with pytest.raises(ValueError, match="detect_every"):
        facesynth.Tracker(detect_every=0)
    with pytest.raises(ValueError, match="fps"):
        facesynth.Tracker(fps=0)
    with pytest.raises(ValueError, match="cut_threshold"):
        facesynth.Tracker(cut_threshold=-1)
    with pytest.raises(ValueError, match="max_reid_distance"):
        facesynth.Tracker(max_reid_distance=float("nan"))
    with pytest.raises(ValueError, match="nodetector"):
        facesynth.Tracker(detector="nodetector")
    broken = tmp_path / "broken.sdm"
    broken.write_text("not a regressor")
    with pytest.raises(RuntimeError, match="broken.sdm"):
        facesynth.Tracker(regressor=broken)
