"""Models, fitting, detection and frontalisation from Python: the same figures as the CLI, arrays
of the documented shapes, ValueError for bad arrays."""

import json
import os
import subprocess
import tempfile

import numpy as np
import pytest

import facesynth
from png_files import read_png

FRONTAL = {"pose": {"yaw": {"min": -10, "max": 10}, "pitch": {"min": -5, "max": 5}, "roll": {"min": -5, "max": 5}},
           "occluders.probability": 0, "landmarks.mode": "contour"}


@pytest.fixture(scope="module")
def model():
    return facesynth.Model("builtin")


@pytest.fixture(scope="module")
def faces():
    return facesynth.Generator(config=FRONTAL, seed=3, size=256, workers=2).batch(0, 3)


def test_model_geometry(model):
    mean = model.vertices()
    assert mean.shape == (model.num_vertices, 3) and mean.dtype == np.float32
    assert np.array_equal(model.vertices(alpha=np.zeros(model.num_shape_components)), mean)
    other = model.vertices(alpha=[1.0, -0.5], expression=np.full(2, 0.3))
    assert other.shape == mean.shape and not np.array_equal(other, mean)
    triangles = model.triangles
    assert triangles.dtype == np.int32 and triangles.shape[1] == 3 and triangles.min() == 0 and triangles.max() < model.num_vertices
    assert model.landmarks(mean).shape == (68, 3)
    assert len(model.checksum) == 16 and model.name
    with pytest.raises(ValueError, match="alpha"):
        model.vertices(alpha=np.zeros(model.num_shape_components + 1))
    with pytest.raises(ValueError, match="vertices"):
        model.landmarks(mean[:10])
    with pytest.raises(RuntimeError, match="missing-model"):
        facesynth.Model("/nonexistent/missing-model.fsm")


def test_fit_gives_the_cli_figures(model, faces, tmp_path):
    landmarks = faces["landmarks"][0]
    fitted = facesynth.fit(landmarks, model)
    assert abs(fitted["yaw_deg"] - faces["pose"][0][0]) < 6
    assert fitted["alpha"].shape == (model.num_shape_components,) and fitted["projected"].shape == (68, 2)
    assert fitted["vertices_px"].shape == (model.num_vertices, 2)
    pts = tmp_path / "face.pts"
    pts.write_text("version: 1\nn_points: 68\n{\n" + "".join(f"{x!r} {y!r}\n" for x, y in landmarks.astype(float)) + "}\n")
    out = tmp_path / "fit"
    subprocess.run([os.environ["FACESYNTH_CLI"], "fit", "--landmarks", str(pts), "--out", str(out), "--quiet"], check=True)
    cli = json.load(open(out / "fit.json"))
    for key in ("yaw_deg", "pitch_deg", "roll_deg", "reprojection_rms_px"):
        assert fitted[key] == pytest.approx(cli[key], abs=1e-6), key
    assert np.allclose(fitted["alpha"], cli["alpha"], atol=1e-6)


def test_fit_refuses_bad_landmarks(model, faces):
    with pytest.raises(ValueError, match=r"\(68, 2\)"):
        facesynth.fit(faces["landmarks"][0][:60], model)
    with pytest.raises(ValueError, match=r"\(68, 2\)"):
        facesynth.fit(faces["landmarks"][0].astype(np.int32), model)
    broken = faces["landmarks"][0].copy()
    broken[30] = np.nan
    with pytest.raises(ValueError, match="landmarks"):
        facesynth.fit(broken, model)
    with pytest.raises(ValueError, match="jaw"):
        facesynth.fit(faces["landmarks"][0], model, jaw="round")


def test_detector_finds_and_landmarks_a_rendered_face(faces):
    detector = facesynth.Detector("dlib")
    found = detector.detect(faces["image"][0])
    assert found, "no face found in a frontal render"
    face = found[0]
    assert face["landmarks"].shape == (68, 2) and len(face["box"]) == 4
    truth = faces["landmarks"][0]
    inter_ocular = np.linalg.norm(truth[36:42].mean(0) - truth[42:48].mean(0))
    assert np.linalg.norm(face["landmarks"] - truth, axis=1).mean() / inter_ocular < 0.2
    assert detector.detect(np.zeros((64, 64), np.uint8)) == []
    with pytest.raises(ValueError, match="uint8"):
        detector.detect(faces["image"][0].astype(np.float32))
    with pytest.raises(RuntimeError, match="nowhere.sdm"):
        facesynth.Detector("/nonexistent/nowhere.sdm")


def test_frontaliser_renders_the_face_frontal(model, faces):
    frontaliser = facesynth.Frontaliser(model, size=128)
    result = frontaliser.frontalise(faces["image"][1], faces["landmarks"][1])
    assert result["frontal"].shape == (128, 128, 3) and result["frontal"].dtype == np.uint8
    assert result["mask"].shape == (128, 128) and (result["mask"] == 255).mean() > 0.2
    assert result["isomap"].ndim == 3 and result["isomap"].shape[2] == 4
    assert abs(result["fit"]["yaw_deg"] - faces["pose"][1][0]) < 6
    with pytest.raises(ValueError, match="landmarks"):
        frontaliser.frontalise(faces["image"][1], np.zeros((68, 2)))
    once = facesynth.frontalise(faces["image"][1], faces["landmarks"][1], model=model, size=128)
    assert np.array_equal(once["frontal"], result["frontal"]) and np.array_equal(once["isomap"], result["isomap"])


def test_accuracy_helpers_give_the_cli_figures(tmp_path):
    flat = {"pose.yaw.min": -10, "pose.yaw.max": 10, "pose.pitch.min": -5, "pose.pitch.max": 5, "occluders.probability": 0}
    data, report, csv = tmp_path / "faces", tmp_path / "eval.json", tmp_path / "nme.csv"
    cli = os.environ["FACESYNTH_CLI"]
    subprocess.run([cli, "synth", "--out", str(data), "--count", "6", "--seed", "11", "--size", "256", "--quiet"]
                   + [a for k, v in flat.items() for a in ("--set", f"{k}={v}")], check=True)
    subprocess.run([cli, "eval", "landmarks", "--regressor", "dlib", "--data", str(data), "--json", str(report), "--nme-csv", str(csv),
                    "--quiet"], check=True)
    rows = [line.split(",") for line in csv.read_text().splitlines()[1:]]
    cli_nmes = np.array([float(r[4]) for r in rows])
    faces = facesynth.Generator(config=flat, seed=11, size=256, workers=2).batch(0, 6)
    detector = facesynth.Detector("dlib")
    for i, row in enumerate(rows):
        assert row[0].endswith(f"s{i:08d}")
        found = detector.detect(faces["image"][i])
        assert bool(found) == (row[2] == "1"), row[0]
        if found:
            ours = min(facesynth.nme(f["landmarks"], faces["landmarks"][i]) for f in found)
            assert ours == pytest.approx(cli_nmes[i], rel=1e-4, abs=1e-6), row[0]
    summary, expected = facesynth.nme_summary(cli_nmes), json.load(open(report))
    assert summary["count"] == 6
    for key in ("nme_mean", "nme_median", "auc_008", "failure_rate_008"):
        assert summary[key] == pytest.approx(expected[key], abs=1e-5), key
    with pytest.raises(ValueError, match="non-negative"):
        facesynth.nme_summary([0.1, float("nan")])
    with pytest.raises(ValueError, match="predicted"):
        facesynth.nme(np.zeros((5, 2)), faces["landmarks"][0])


def test_renderer_renders_an_instance_like_the_cli(model, tmp_path):
    renderer = facesynth.Renderer(model)
    alpha = np.linspace(-1, 1, model.num_shape_components).astype(np.float32)
    out = renderer.render(alpha=alpha, yaw=25, size=(160, 128))
    assert out["image"].shape == (128, 160, 3) and out["image"].dtype == np.uint8
    assert out["mask"].shape == (128, 160) and out["depth"].dtype == np.float32 and out["normals"].shape == (128, 160, 3)
    assert out["landmarks_contour"].shape == (68, 2) and out["visible_fixed"].dtype == np.bool_
    points = np.c_[model.landmarks(model.vertices(alpha)), np.ones(68)] @ out["camera"].T
    assert np.abs(points[:, :2] / points[:, 2:] - out["landmarks_fixed"]).max() < 1e-3
    # `facesynth render --yaw 25` of the mean face draws the same pixels.
    mean = renderer.render(yaw=25, size=128)
    subprocess.run([os.environ["FACESYNTH_CLI"], "render", "--yaw", "25", "--size", "128", "--out", str(tmp_path / "r"), "--quiet"], check=True)
    cli = json.load(open(tmp_path / "r" / "render.json"))
    assert np.allclose(np.array(cli["landmarks_contour"]), mean["landmarks_contour"], atol=1e-9)
    assert np.array_equal(read_png(tmp_path / "r" / "image.png"), mean["image"])
    assert np.array_equal(read_png(tmp_path / "r" / "mask.png"), mean["mask"])
    # A random face drawn as `render --seed` draws it.
    face = model.sample(seed=5)
    assert face["alpha"].shape == (model.num_shape_components,) and face["alpha"].dtype == np.float32
    assert np.abs(face["alpha"]).max() <= 3
    drawn = renderer.render(alpha=face["alpha"], colour=face["colour"], yaw=10, size=96)
    subprocess.run([os.environ["FACESYNTH_CLI"], "render", "--seed", "5", "--yaw", "10", "--size", "96", "--out", str(tmp_path / "s"), "--quiet"],
                   check=True)
    assert np.array_equal(read_png(tmp_path / "s" / "image.png"), drawn["image"])
    assert not np.array_equal(model.sample(seed=6)["alpha"], face["alpha"])
    with pytest.raises(ValueError, match="anti-aliasing"):
        facesynth.Renderer(model, antialiasing="fuzzy")
    with pytest.raises(ValueError, match="fov"):
        renderer.render(fov=0)


def test_eval_helpers_give_the_cli_figures(model, tmp_path):
    cli = os.environ["FACESYNTH_CLI"]
    timing = ("ms_per_fit", "cpu_ms_per_fit", "cpu_ms_per_face")

    def same_figures(ours, path):
        theirs = json.load(open(path))
        assert set(ours) == set(theirs)
        for key, value in theirs.items():
            if not key.endswith(timing):
                assert ours[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key

    # eval fit on cases generated in code, and on a rendered dataset.
    generated = facesynth.eval_fit(model, count=12, seed=5, noise=1.0)
    subprocess.run([cli, "eval", "fit", "--count", "12", "--seed", "5", "--noise", "1", "--json", str(tmp_path / "g.json"), "--quiet"], check=True)
    same_figures(generated, tmp_path / "g.json")
    assert generated["count"] == 12 and generated["vertex_rmse_mm"] < generated["vertex_rmse_mm_meanshape"]
    data = tmp_path / "faces"
    subprocess.run([cli, "synth", "--out", str(data), "--count", "5", "--seed", "11", "--size", "256", "--quiet",
                    "--set", "pose.yaw.min=-10", "--set", "pose.yaw.max=10", "--set", "occluders.probability=0"], check=True)
    on_data = facesynth.eval_fit(data=data, mode="fixed", refine=True)
    subprocess.run([cli, "eval", "fit", "--data", str(data), "--mode", "fixed", "--refine", "--json", str(tmp_path / "d.json"), "--quiet"],
                   check=True)
    same_figures(on_data, tmp_path / "d.json")
    assert on_data["count"] == 5 and on_data["failed"] == 0
    # eval realism, the dataset standing in for the photographs too.
    realism = facesynth.eval_realism(data, photos=data)
    subprocess.run([cli, "eval", "realism", "--data", str(data), "--photos", str(data), "--json", str(tmp_path / "r.json"), "--quiet"], check=True)
    same_figures(realism, tmp_path / "r.json")
    assert realism["renders_faces"] == 5 and realism["nme_ratio"] == pytest.approx(1.0)
    matched = facesynth.eval_realism(data, photos=data, match_face_size=True)
    subprocess.run([cli, "eval", "realism", "--data", str(data), "--photos", str(data), "--match-face-size", "--json", str(tmp_path / "rm.json"),
                    "--quiet"], check=True)
    same_figures(matched, tmp_path / "rm.json")
    assert matched["match_face_size"] and not realism["match_face_size"]
    assert matched["photos_scale_median"] == pytest.approx(1.0)  # the same faces: already the renders' size

    # eval frontalise from true landmarks.
    frontalised = facesynth.eval_frontalise(model, count=1, isomap_size=128, size=96, image_size=160, lighting="sky")
    subprocess.run([cli, "eval", "frontalise", "--count", "1", "--isomap-size", "128", "--size", "96", "--image-size", "160", "--lighting", "sky",
                    "--json", str(tmp_path / "f.json"), "--quiet"], check=True)
    same_figures(frontalised, tmp_path / "f.json")
    assert frontalised["count"] == 1 and frontalised["lighting"] == "sky"

    with pytest.raises(ValueError, match="lighting"):
        facesynth.eval_frontalise(model, count=1, lighting="noon")
    with pytest.raises(ValueError, match="mode"):
        facesynth.eval_fit(model, data=data, mode="wobbly")
    with pytest.raises(ValueError, match="max_yaw"):
        facesynth.eval_fit(model, max_yaw=120)
    with pytest.raises(ValueError, match="landmark"):
        facesynth.eval_fit(model, count=2, landmarks="12")
    with pytest.raises(RuntimeError, match="manifest.jsonl"):
        facesynth.eval_fit(model, data=tmp_path / "missing")
    (data / "meta" / "s00000002.json").write_text("{not json")
    with pytest.raises(RuntimeError, match="1 of 5 samples.*\n.*s00000002"):
        facesynth.eval_fit(model, data=data)
    with pytest.raises(RuntimeError, match="no render"):
        facesynth.eval_realism(data, max_yaw=0)
    with pytest.raises(ValueError, match="max_yaw"):
        facesynth.eval_realism(data, max_yaw=-1)
