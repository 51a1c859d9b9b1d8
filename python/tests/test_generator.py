"""The facesynth Python package's generator: the same samples as `facesynth synth`, arrays of the
documented shapes and types, determinism across workers and shards, and clear errors.
Run by CTest (test `python`) with PYTHONPATH at the build tree's package and FACESYNTH_CLI."""

import json
import os
import subprocess
import tempfile
import threading

import numpy as np
import pytest

import facesynth
from png_files import read_png

SIZE = 96
# Small, fast samples that still exercise the labels; every optional array on.
CONFIG = {"output": {"mask": True, "labels": True, "depth": True, "normals": True}, "pose.yaw.max": 50}


@pytest.fixture(scope="module")
def gen():
    return facesynth.Generator(config=CONFIG, seed=7, size=SIZE, workers=2)


def test_arrays_have_the_documented_shapes_and_types(gen):
    batch = gen.batch(3, 2)
    n, k = 2, batch["alpha"].shape[1]
    expected = {
        "image": ((n, SIZE, SIZE, 3), np.uint8),
        "landmarks": ((n, 68, 2), np.float32),
        "landmarks_3d": ((n, 68, 3), np.float32),
        "visible": ((n, 68), np.bool_),
        "pose": ((n, 3), np.float32),
        "alpha": ((n, k), np.float32),
        "camera": ((n, 3, 4), np.float64),
        "fov": ((n,), np.float32),
        "mask": ((n, SIZE, SIZE), np.uint8),
        "labels": ((n, SIZE, SIZE), np.uint8),
        "depth": ((n, SIZE, SIZE), np.float32),
        "normals": ((n, SIZE, SIZE, 3), np.float32),
    }
    assert set(batch) == set(expected) | {"expression"}
    for key, (shape, dtype) in expected.items():
        assert batch[key].shape == shape, key
        assert batch[key].dtype == dtype, key
    assert batch["expression"].shape[0] == n and batch["expression"].dtype == np.float32
    assert k > 0
    # Without the optional outputs only the always-present arrays come back.
    plain = facesynth.Generator(seed=7, size=SIZE, workers=1).batch(0, 1)
    assert not {"mask", "labels", "depth", "normals"} & set(plain)
    # A sample is the batch's row: gen[i] drops the leading dimension.
    single = gen[3]
    assert single["image"].shape == (SIZE, SIZE, 3)
    assert np.array_equal(single["image"], batch["image"][0])


def test_camera_projects_the_3d_landmarks_onto_the_2d_ones(gen):
    batch = gen.batch(0, 4)
    for i in range(4):
        points = np.c_[batch["landmarks_3d"][i].astype(np.float64), np.ones(68)] @ batch["camera"][i].T
        projected = points[:, :2] / points[:, 2:]
        assert np.abs(projected - batch["landmarks"][i]).max() < 0.05


def test_samples_equal_the_cli_dataset_byte_for_byte(gen):
    cli = os.environ["FACESYNTH_CLI"]
    tmp = os.environ.get("FACESYNTH_TEST_TMP", tempfile.gettempdir())
    os.makedirs(tmp, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=tmp) as out:
        subprocess.run([cli, "synth", "--out", out, "--count", "4", "--seed", "7", "--size", str(SIZE), "--threads", "2", "--quiet",
                        "--set", "output.mask=true", "--set", "output.labels=true", "--set", "output.depth=true",
                        "--set", "output.normals=true", "--set", "pose.yaw.max=50"], check=True)
        batch = gen.batch(0, 4)
        for i in range(4):
            key = f"s{i:08d}"
            assert np.array_equal(read_png(f"{out}/images/{key}.png"), batch["image"][i]), key
            assert np.array_equal(read_png(f"{out}/mask/{key}.png"), batch["mask"][i]), key
            assert np.array_equal(read_png(f"{out}/labels/{key}.png"), batch["labels"][i]), key
            meta = json.load(open(f"{out}/meta/{key}.json"))
            assert np.allclose(np.array(meta["landmarks"], np.float32), batch["landmarks"][i], atol=1e-4), key
            assert np.array_equal(np.array(meta["visibility"], bool), batch["visible"][i]), key
            assert np.allclose([meta["yaw"], meta["pitch"], meta["roll"]], batch["pose"][i], atol=1e-4), key
            assert np.allclose(np.array(meta["alpha"], np.float32), batch["alpha"][i]), key


def test_samples_do_not_depend_on_workers_or_batching(gen):
    one = facesynth.Generator(config=CONFIG, seed=7, size=SIZE, workers=1).batch(0, 5)
    three = facesynth.Generator(config=CONFIG, seed=7, size=SIZE, workers=3).batch(0, 5)
    parts = [gen.batch(0, 2), gen.batch(2, 3)]
    for key in one:
        assert np.array_equal(one[key], three[key]), key
        assert np.array_equal(one[key], np.concatenate([p[key] for p in parts])), key
    other_seed = facesynth.Generator(config=CONFIG, seed=8, size=SIZE, workers=1).batch(0, 1)
    assert not np.array_equal(other_seed["image"][0], one["image"][0])


def test_shards_together_yield_every_batch_once(gen):
    whole = gen.batch(0, 7)["image"]
    shards = [list(gen.batches(2, start=0, stop=7, shard=(k, 2))) for k in range(2)]
    assert [len(b["image"]) for b in shards[0]] == [2, 2] and [len(b["image"]) for b in shards[1]] == [2, 1]
    interleaved = [shards[0][0], shards[1][0], shards[0][1], shards[1][1]]
    assert np.array_equal(np.concatenate([b["image"] for b in interleaved]), whole)
    endless = gen.batches(3, start=5)
    assert np.array_equal(next(endless)["image"][:2], whole[5:7])
    assert facesynth.worker_shard() == (0, 1)


def test_two_python_threads_share_a_generator(gen):
    expected = gen.batch(0, 3)["image"]
    results, errors = {}, []

    def work(name):
        try:
            results[name] = [gen.batch(0, 3)["image"] for _ in range(2)]
        except Exception as error:  # reported below: a thread's exception would otherwise be lost
            errors.append(error)

    threads = [threading.Thread(target=work, args=(n,)) for n in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors and all(not t.is_alive() for t in threads)
    for images in results.values():
        assert all(np.array_equal(i, expected) for i in images)


def test_config_is_resolved_like_the_cli(gen, tmp_path):
    assert gen.seed == 7 and gen.size == (SIZE, SIZE) and gen.workers == 2
    assert gen.config["pose"]["yaw"]["max"] == 50 and gen.config["output"]["mask"] is True
    toml = tmp_path / "c.toml"
    toml.write_text(gen.config_toml)
    again = facesynth.Generator(config=toml, workers=1)
    assert again.config == gen.config
    assert np.array_equal(again[1]["image"], gen[1]["image"])
    assert len(facesynth.Generator(config={"count": 12}, workers=1)) == 12


@pytest.mark.parametrize("config, named", [
    ({"pose": {"yaw": {"maxx": 3}}}, "pose.yaw.maxx"),
    ({"seed": "seven"}, "'seed'"),
    ({"camera.width": 1.5}, "camera.width"),
    ({"pose.yaw.min": 10, "pose.yaw.max": 5}, "pose.yaw.min"),
    ({"camera.fov_max": float("nan")}, "camera.fov_max"),
    ({"camera": {"fov_min": float("inf")}}, "camera.fov_min"),
    ({"identity": [1, 2]}, "identity"),
])
def test_bad_config_raises_value_error_naming_the_key(config, named):
    with pytest.raises(ValueError, match=named.replace(".", r"\.")):
        facesynth.Generator(config=config, workers=1)


def test_bad_arguments_raise_clear_errors(gen, tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.toml"):
        facesynth.Generator(config=str(tmp_path / "nowhere.toml"))
    broken = tmp_path / "broken.toml"
    broken.write_text("[pose\nyaw = ")
    with pytest.raises(ValueError, match="broken.toml"):
        facesynth.Generator(config=broken)
    with pytest.raises(RuntimeError, match="no-such-model.fsm"):
        facesynth.Generator(model=str(tmp_path / "no-such-model.fsm"))
    with pytest.raises(ValueError, match="workers"):
        facesynth.Generator(workers=0)
    with pytest.raises(ValueError, match="size"):
        facesynth.Generator(size=(0, 10))
    with pytest.raises(TypeError, match="config"):
        facesynth.Generator(config=[("seed", 1)])
    with pytest.raises(ValueError, match="start"):
        gen.batch(-1, 2)
    with pytest.raises(ValueError, match="count"):
        gen.batch(0, 0)
    with pytest.raises(TypeError, match="index"):
        gen["3"]
    with pytest.raises(ValueError, match="shard"):
        next(gen.batches(2, shard=(2, 2)))
