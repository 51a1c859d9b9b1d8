"""tools/nme_factors.py: per-face NMEs joined with the samples' meta files."""

import json
import os
import subprocess
import sys

TOOL = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "nme_factors.py")


def run(*args):
    return subprocess.run([sys.executable, TOOL, *map(str, args)], capture_output=True, text=True)


def test_correlations_bins_and_texture_split_half(tmp_path):
    (tmp_path / "meta").mkdir()
    rows = ["key,yaw_deg,detected,view,regressor1,regressor2"]
    for i in range(40):
        pitch = -20 + i  # NME grows with |pitch|; roll is unrelated
        meta = {"yaw": 0.5 * i, "pitch": pitch, "roll": 3.0 if i % 2 else -5.0, "fov": 10,
                "degradation": {"blur_sigma": 0.0, "gains": [1.0, 1.0, 1.0]}, "texture": f"textures/{i % 10:06d}.png",
                "landmarks": [[0, 0]] * 36 + [[10, 0]] + [[0, 0]] * 8 + [[40 + i, 0]] + [[0, 0]] * 22}
        (tmp_path / "meta" / f"s{i:08d}.json").write_text(json.dumps(meta))
        rows.append(f"links/s{i:08d},{meta['yaw']},{0 if i == 39 else 1},frontal,{0.02 + 0.002 * abs(pitch)},0.05")
    (tmp_path / "nme.csv").write_text("\n".join(rows) + "\n")
    result = run(tmp_path / "nme.csv", tmp_path, "--bins", "4")
    assert result.returncode == 0, result.stderr
    lines = {line.split()[0]: line for line in result.stdout.splitlines() if line}
    assert "39 detected faces" in result.stdout  # the missed face is left out
    assert float(lines["abs_pitch"].split()[1]) > 0.99
    assert abs(float(lines["abs_roll"].split()[1])) < 0.2
    assert lines["abs_pitch"].count("(") == 4
    assert "degradation.blur_sigma" not in lines  # one value: nothing to relate
    assert lines["interocular_px"].split()[2].startswith("30..")  # outer eye corners 36 and 45: 30 + i pixels apart
    assert "over 10 textures" in lines["texture:"]


def test_bad_inputs_name_the_file(tmp_path):
    (tmp_path / "nme.csv").write_text("key,yaw_deg,detected,view,regressor1\nx/s1,0,1,frontal,0.05\n")
    result = run(tmp_path / "nme.csv", tmp_path)
    assert result.returncode != 0 and "s1.json" in result.stderr
    result = run(tmp_path / "nme.csv", tmp_path, "--column", "3")
    assert result.returncode != 0 and "regressor3" in result.stderr
    result = run(tmp_path / "missing.csv", tmp_path)
    assert result.returncode != 0 and "missing.csv" in result.stderr


def test_directional_lights_counted_and_max_yaw_keeps_the_near_frontal_faces(tmp_path):
    (tmp_path / "meta").mkdir()
    rows = ["key,yaw_deg,detected,view,regressor1"]
    for i in range(30):
        lights = [{"colour": [0.3, 0.3, 0.3], "direction": [0, 0.4, 1]}] * (i % 3)
        meta = {"yaw": -45 + 3 * i, "lighting": {"lights": lights, "shadows": bool(lights)}}
        (tmp_path / "meta" / f"s{i:08d}.json").write_text(json.dumps(meta))
        rows.append(f"d/s{i:08d},{meta['yaw']},1,frontal,{0.06 - 0.01 * len(lights)}")
    (tmp_path / "nme.csv").write_text("\n".join(rows) + "\n")
    result = run(tmp_path / "nme.csv", tmp_path, "--max-yaw", 20)
    assert result.returncode == 0, result.stderr
    assert "13 detected faces" in result.stdout  # yaw -45 + 3i within 20 degrees: i = 9..21
    lines = {line.split()[0]: line for line in result.stdout.splitlines() if line}
    assert float(lines["lighting.directional_lights"].split()[1]) < -0.99
    assert "0: 0.0600" in lines["lighting.directional_lights"] and "2: 0.0400" in lines["lighting.directional_lights"]
    result = run(tmp_path / "nme.csv", tmp_path, "--max-yaw", -1)
    assert result.returncode != 0 and "--max-yaw" in result.stderr


def test_bank_relates_each_textures_mean_nme_to_its_numbers_and_lists_the_worst(tmp_path):
    (tmp_path / "meta").mkdir()
    rows = ["key,yaw_deg,detected,view,regressor1"]
    for i in range(40):
        texture = i % 8  # five renders each; texture t's renders are harder the higher its fit error
        (tmp_path / "meta" / f"s{i:08d}.json").write_text(json.dumps({"yaw": 0, "texture": f"textures/{texture:06d}.png"}))
        rows.append(f"d/s{i:08d},0,1,frontal,{0.03 + 0.01 * texture + 0.001 * (i % 3)}")
    (tmp_path / "nme.csv").write_text("\n".join(rows) + "\n")
    bank = tmp_path / "bank"
    bank.mkdir()
    textures = [{"file": f"textures/{t:06d}.png", "fit_error": 0.01 * t, "seen_share": 0.6 + 0.01 * ((t * 5) % 8),
                 "source": f"photos/p{t}.jpg", "landmarks_source": "pts"} for t in range(8)]
    (bank / "bank.json").write_text(json.dumps({"textures": textures}))
    result = run(tmp_path / "nme.csv", tmp_path, "--bank", bank, "--worst", 2)
    assert result.returncode == 0, result.stderr
    lines = {line.split()[0]: line for line in result.stdout.splitlines() if line.startswith("  ")}
    assert float(lines["fit_error"].split()[1]) > 0.99
    assert abs(float(lines["seen_share"].split()[1])) < 0.9
    assert "landmarks_source" not in lines  # not a number
    worst = [line for line in result.stdout.splitlines() if line.startswith("worst:")]
    assert len(worst) == 2 and "000007.png" in worst[0] and "photos/p7.jpg" in worst[0] and "000006.png" in worst[1]
    (bank / "bank.json").write_text("{")
    result = run(tmp_path / "nme.csv", tmp_path, "--bank", bank)
    assert result.returncode != 0 and "bank.json" in result.stderr
