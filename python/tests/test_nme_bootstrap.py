"""tools/nme_bootstrap.py: paired bootstrap of per-face NMEs, ratio targets and the yaw split."""

import os
import subprocess
import sys

TOOL = os.path.join(os.path.dirname(__file__), "..", "..", "tools", "nme_bootstrap.py")


def run(*args):
    return subprocess.run([sys.executable, TOOL, *map(str, args)], capture_output=True, text=True)


def write_csv(path, rows, with_yaw=True):
    lines = ["key,yaw_deg,detected,view,regressor1,regressor2"]
    for key, yaw, detected, ours, reference in rows:
        lines.append(f"{key},{yaw if with_yaw else ''},{detected},frontal,{ours},{reference}")
    path.write_text("\n".join(lines) + "\n")


def line_of(output, label, name):
    """The paired line of one group (yaw<=40, all, ...) and one regressor."""
    for line in output.splitlines():
        words = line.split()
        if len(words) > 2 and words[0] == label and words[1] == name:
            return line
    raise AssertionError(f"no '{label} {name}' line in:\n{output}")


def test_ratio_and_yaw_split(tmp_path):
    # ours is 0.04 on the 20 faces within 40 degrees and 0.08 on the 10 beyond; the reference 0.03 and 0.10.
    rows = [(f"f{i}", 10 + i, 1, 0.04, 0.03) for i in range(20)]
    rows += [(f"g{i}", -45 - i, 1, 0.08, 0.10) for i in range(10)]
    rows.append(("missed", 5, 0, "inf", "inf"))  # a detector miss is left out of every group
    write_csv(tmp_path / "nme.csv", rows)
    result = run(tmp_path / "nme.csv", "--reference", 2, "--names", "ours,ref", "--yaw-split", 40)
    assert result.returncode == 0, result.stderr
    assert "31 faces, 30 detected" in result.stdout
    assert "+0.0100 [+0.0100, +0.0100], reference better on 20 of 20" in line_of(result.stdout, "yaw<=40", "ours")
    assert "-0.0200 [-0.0200, -0.0200], reference better on 0 of 10" in line_of(result.stdout, "yaw>40", "ours")

    # Within 1.4 x the reference below 40 degrees (0.04 - 1.4 * 0.03 = -0.002): met on every face.
    result = run(tmp_path / "nme.csv", "--reference", 2, "--names", "ours,ref", "--yaw-split", 40, "--ratio", 1.4)
    assert result.returncode == 0, result.stderr
    below = line_of(result.stdout, "yaw<=40", "ours")
    assert "ours - 1.4 x ref: -0.0020 [-0.0020, -0.0020], above it on 0 of 20" in below
    assert "above it on 0 of 10" in line_of(result.stdout, "yaw>40", "ours")

    # Without --yaw-split there are no split groups.
    result = run(tmp_path / "nme.csv", "--reference", 2)
    assert result.returncode == 0 and "yaw<=" not in result.stdout


def test_bad_inputs_say_what_is_wrong(tmp_path):
    write_csv(tmp_path / "nme.csv", [("f0", 0, 1, 0.04, 0.03), ("f1", 0, 1, 0.05, 0.03)])
    result = run(tmp_path / "nme.csv", "--reference", 3)
    assert result.returncode != 0 and "--reference 3" in result.stderr and "2 regressor columns" in result.stderr
    result = run(tmp_path / "nme.csv", "--ratio", 0)
    assert result.returncode != 0 and "--ratio" in result.stderr
    result = run(tmp_path / "missing.csv")
    assert result.returncode != 0 and "missing.csv" in result.stderr
    write_csv(tmp_path / "noyaw.csv", [("f0", 0, 1, 0.04, 0.03)], with_yaw=False)
    result = run(tmp_path / "noyaw.csv", "--yaw-split", 40)
    assert result.returncode != 0 and "noyaw.csv" in result.stderr and "yaw_deg" in result.stderr
    (tmp_path / "empty.csv").write_text("key,yaw_deg,detected,view,regressor1\n")
    result = run(tmp_path / "empty.csv")
    assert result.returncode != 0 and "empty.csv: no faces" in result.stderr


def test_several_files_pair_by_sample_name(tmp_path):
    # Two datasets rendered with one setting changed: the same sample names under different folders.
    (tmp_path / "a.csv").write_text("key,yaw_deg,detected,view,regressor1\n"
                                     "set_a/s0,5,1,frontal,0.05\nset_a/s1,-30,1,frontal,0.07\n"
                                     "set_a/s2,0,1,frontal,0.06\nset_a/only_here,0,1,frontal,0.9\n")
    (tmp_path / "b.csv").write_text("key,yaw_deg,detected,view,regressor1\n"
                                     "set_b/s1,-30,1,frontal,0.06\nset_b/s0,5,1,frontal,0.04\n"
                                     "set_b/s2,0,0,,inf\n")
    result = run(tmp_path / "a.csv", tmp_path / "b.csv", "--names", "a,b", "--yaw-split", 20)
    assert result.returncode == 0, result.stderr
    assert "3 faces, 2 detected" in result.stdout  # only_here is in one file; s2 was missed in b
    assert "-0.0100 [-0.0100, -0.0100], reference better on 0 of 2" in line_of(result.stdout, "all", "b")
    assert "reference better on 0 of 1" in line_of(result.stdout, "yaw<=20", "b")

    (tmp_path / "twice.csv").write_text("key,yaw_deg,detected,view,regressor1\nx/s0,0,1,frontal,0.1\ny/s0,0,1,frontal,0.2\n")
    result = run(tmp_path / "a.csv", tmp_path / "twice.csv")
    assert result.returncode != 0 and "twice.csv" in result.stderr and "'s0'" in result.stderr
    (tmp_path / "other.csv").write_text("key,yaw_deg,detected,view,regressor1\nz/q9,0,1,frontal,0.1\n")
    result = run(tmp_path / "a.csv", tmp_path / "other.csv")
    assert result.returncode != 0 and "no face is in every file" in result.stderr


def test_fail_at_compares_failure_rates_over_the_detected_faces(tmp_path):
    # ours fails (> 0.08) on faces 0-3, the reference on faces 0-9; face 10 is a miss and left out.
    rows = [(f"f{i}", 0, 0 if i == 10 else 1, 0.09 if i < 4 else 0.03, 0.09 if i < 10 else 0.02) for i in range(20)]
    write_csv(tmp_path / "nme.csv", rows)
    result = run(tmp_path / "nme.csv", "--names", "ours,ref", "--reference", 2, "--fail-at", 0.08)
    assert result.returncode == 0, result.stderr
    assert "19 detected; 5000 resamples; failure rates at 0.08" in result.stdout
    assert "ours: mean 0.2105" in result.stdout  # 4 of 19
    line = line_of(result.stdout, "all", "ours")
    assert "-0.3158" in line and "means 0.2105 vs 0.5263" in line  # (4 - 10) / 19
    result = run(tmp_path / "nme.csv", "--fail-at", 0.08, "--ratio", 1.2)
    assert result.returncode != 0 and "--fail-at" in result.stderr
    result = run(tmp_path / "nme.csv", "--fail-at", -1)
    assert result.returncode != 0 and "--fail-at" in result.stderr
