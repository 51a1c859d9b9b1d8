#!/usr/bin/env python3
"""tools/nme_groups.py on made-up faces: errors per group, offsets, the turn trend, the jaw's directions and
--nme-csv (ctest runs it)."""
import math
import os
import subprocess
import sys
import tempfile

TOOL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "nme_groups.py")


def face(turn):
    """68 points with the outer eye corners 100 px apart and eyes whose widths differ by `turn`."""
    points = [(200.0 + 5 * i, 300.0 + 3 * (i % 7)) for i in range(68)]
    left_width, right_width = 30 * (1 + turn), 30 * (1 - turn)
    # Both eyes on one horizontal line, so that the face frame is the image's: corners 37 and 40 (outer,
    # inner) of the left eye, 43 and 46 (inner, outer) of the right, the lids' points between them.
    for i, t in enumerate([0, 1 / 3, 2 / 3, 1, 2 / 3, 1 / 3]):
        points[36 + i] = (150.0 + left_width * t, 200.0)
        points[42 + i] = (250.0 - right_width * (1 - t), 200.0)
    return points


def write_pts(path, points):
    with open(path, "w") as f:
        f.write("version: 1\nn_points: 68\n{\n" + "".join(f"{x:.4f} {y:.4f}\n" for x, y in points) + "}\n")


def run(*args):
    result = subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"nme_groups.py {' '.join(args)} failed: {result.stderr}")
    return result.stdout


def main():
    with tempfile.TemporaryDirectory() as tmp:
        gt, det = os.path.join(tmp, "gt"), os.path.join(tmp, "det")
        os.makedirs(gt)
        os.makedirs(det)
        for k, turn in enumerate([-0.1, -0.05, 0.0, 0.05, 0.1]):
            truth = face(turn)
            eye_width = math.dist(truth[36], truth[45])
            found = list(truth)
            asymmetry = turn  # (wl - wr) / (wl + wr) of face(turn)
            # Point 9 drifts along the eye line by 0.03 inter-ocular distances per 0.1 of asymmetry;
            # point 31 sits 0.05 below its annotation on every face.
            found[8] = (truth[8][0] + 0.3 * asymmetry * eye_width, truth[8][1])
            found[30] = (truth[30][0], truth[30][1] + 0.05 * eye_width)
            write_pts(os.path.join(gt, f"face{k}.pts"), truth)
            write_pts(os.path.join(det, f"face{k}_0.pts"), found)
        out = run(gt, det, "--turn-trend")
        if "5 of 5 faces found" not in out:
            sys.exit(f"expected all five faces:\n{out}")
        if "31:+0.000,+0.050" not in out:
            sys.exit(f"expected point 31's offset of 0.05 below:\n{out}")
        trend = next((line for line in out.splitlines() if "per 0.1 eye asymmetry" in line), "")
        if trend.split(":", 1)[1].split() != ["9:+0.030"]:
            sys.exit(f"expected point 9's trend of +0.030 per 0.1 and no other:\n{out}")
        if "its turn trend too 0.0000" not in out:
            sys.exit(f"with the mean offsets and the trend taken off, nothing is left:\n{out}")
        csv = os.path.join(tmp, "point31.csv")
        run(gt, det, det, "--points", "31", "--nme-csv", csv)
        with open(csv) as f:
            lines = f.read().splitlines()
        if lines[0] != "key,yaw_deg,detected,view,regressor1,regressor2" or len(lines) != 6:
            sys.exit(f"expected eval landmarks' header for two folders and five faces:\n{lines}")
        for k, line in enumerate(lines[1:]):
            key, yaw, detected, view, first, second = line.split(",")
            if key != f"face{k}" or yaw or detected != "1" or view or abs(float(first) - 0.05) > 1e-6 or first != second:
                sys.exit(f"expected face{k} with point 31's error of 0.05 in both columns: {line}")
        # The jaw: a second folder whose point 5 slides 0.17 inter-ocular distances along the annotated
        # outline (from point 4 toward point 6) and point 12 0.34 across it, on every face.
        jaw = os.path.join(tmp, "jaw")
        os.makedirs(jaw)
        for k in range(5):
            truth = face([-0.1, -0.05, 0.0, 0.05, 0.1][k])
            eye_width = math.dist(truth[36], truth[45])
            moved = list(truth)
            for i, size, across in ((4, 0.17, False), (11, 0.34, True)):
                a, b = truth[i - 1], truth[i + 1]
                length = math.dist(a, b)
                tx, ty = (b[0] - a[0]) / length, (b[1] - a[1]) / length
                dx, dy = (-ty, tx) if across else (tx, ty)
                moved[i] = (truth[i][0] + size * eye_width * dx, truth[i][1] + size * eye_width * dy)
            write_pts(os.path.join(jaw, f"face{k}_0.pts"), moved)
        directions = run(gt, jaw, "--jaw-directions")
        if "jaw along its outline 0.0100, across it 0.0200" not in directions:
            sys.exit(f"expected 0.17 / 17 along the jaw and 0.34 / 17 across it:\n{directions}")
        without = run(gt, det)
        if "jaw along" in without:
            sys.exit(f"the jaw's directions are printed only with --jaw-directions:\n{without}")
        if "eye asymmetry" in without:
            sys.exit(f"the trend is printed only with --turn-trend:\n{without}")
    print("nme_groups.py: groups, offsets, turn trend, the jaw's directions and per-face errors as made")


if __name__ == "__main__":
    main()
