#!/usr/bin/env python3
"""Error per landmark group and mean signed offset per landmark, from `facesynth detect` output.

    facesynth detect --regressor MODEL.sdm --detector dlib --out DET --quiet GT/*.jpg GT/*.png
    tools/nme_groups.py GT DET [DET2 ...]
    tools/nme_groups.py GT DET --write-offsets OFFSETS.json   # label adaptation: train --label-offsets
    tools/nme_groups.py GT DET [DET2 ...] --points 1-3,15-17      # also the mean error over these points
    tools/nme_groups.py GT DET [DET2 ...] --turn-trend            # offsets that grow with the head's turn
    tools/nme_groups.py GT DET [DET2 ...] --points 18-68 --nme-csv inner.csv   # per face, for tools/nme_bootstrap.py
    tools/nme_groups.py GT DET [DET2 ...] --jaw-directions    # the jaw's error along its outline and across it

For every GT/NAME.pts with a detection DET/NAME_<k>.pts (the detection nearest the annotation when there
are several), on the faces every DET folder found: the mean point error per group (jaw 1-17, brows 18-27,
nose 28-36, eyes 37-48, mouth 49-68) in inter-ocular distances (outer eye corners), and the landmarks whose
mean offset (prediction - annotation, face frame: x along the eye line, y down) exceeds 0.03.
--write-offsets writes, for one DET folder, the mean (annotation - prediction) per landmark in the keys
`train --label-offsets` reads (mean_x_NN, mean_y_NN, as `eval conventions --json`): the training labels
then move by the detector's mean bias on these annotations (docs/results.md, "Label adaptation").
--nme-csv writes, per face found in every folder, the mean point error (inter-ocular) over --points (all
68 without it) of each folder, in the layout of `facesynth eval landmarks --nme-csv` (key = the .pts name,
yaw_deg and view empty, regressorK = the K-th folder), so that tools/nme_bootstrap.py can pair them.
--turn-trend also prints, per folder, the landmarks whose x offset changes with the head's turn: the
least-squares slope of the offset along the eye line on the annotation's eye-width asymmetry
(wl - wr) / (wl + wr) (outer to inner corner, each eye; about 0.05 per 10 degrees of yaw, a measure that
needs no model; positive when the nose points to the image's right), per 0.1 of asymmetry, where it
exceeds 0.01 inter-ocular distances. A positive slope is a point that moves with the turn further than
the annotation does, as a point in front of the annotators' would (or one the detector turns too far). It
also prints the mean error left once each landmark's mean offset, and then its trend too, are taken off
(fitted on the same faces: a bound on what label conventions can be worth to that detector there).
--jaw-directions also prints, per folder, the mean size of the 17 jaw points' offsets along the annotated
jaw outline (the direction from the point's annotated neighbour before it to the one after it; at the ends,
to or from its one neighbour) and across it: a jaw point can slide along the outline, where the image
says least about it.
"""
import argparse
import glob
import json
import math
import os
import sys

GROUPS = {"jaw": range(0, 17), "brows": range(17, 27), "nose": range(27, 36), "eyes": range(36, 48), "mouth": range(48, 68)}


def read_pts(path):
    with open(path) as f:
        text = f.read()
    try:
        values = [float(v) for v in text.split("{", 1)[1].split("}", 1)[0].split()]
    except (IndexError, ValueError):
        sys.exit(f"{path}: not a .pts file")
    if len(values) != 136:
        sys.exit(f"{path}: {len(values) // 2} points, expected 68")
    return [(values[2 * i], values[2 * i + 1]) for i in range(68)]


def mean_of(points, indices):
    return (sum(points[i][0] for i in indices) / len(indices), sum(points[i][1] for i in indices) / len(indices))


def eye_asymmetry(points):
    """(wl - wr) / (wl + wr) of the two eyes' corner-to-corner widths: grows with the head's turn."""
    left, right = math.dist(points[36], points[39]), math.dist(points[42], points[45])
    return (left - right) / (left + right)


def jaw_directions(gt, p):
    """Summed |offset| of the 17 jaw points along the annotated outline and across it, in pixels."""
    along = across = 0.0
    for i in range(17):
        before, after = gt[max(i - 1, 0)], gt[min(i + 1, 16)]
        length = math.dist(before, after)
        t = ((after[0] - before[0]) / length, (after[1] - before[1]) / length) if length > 0 else (1.0, 0.0)
        d = (p[i][0] - gt[i][0], p[i][1] - gt[i][1])
        along += abs(d[0] * t[0] + d[1] * t[1])
        across += abs(d[1] * t[0] - d[0] * t[1])
    return along, across


def slope(xs, ys):
    """Least-squares slope of ys on xs (0 when xs do not vary)."""
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else 0.0


def bias_free_error(turns, x_offsets, y_offsets, with_trend):
    """Mean point error (inter-ocular) once each landmark's mean offset (and, with_trend, its x offset's
    linear trend on the eye asymmetry) is taken off, both fitted on the same faces."""
    mean_turn = sum(turns) / len(turns)
    total = 0.0
    for i in range(68):
        xs, ys = [row[i] for row in x_offsets], [row[i] for row in y_offsets]
        trend = slope(turns, xs) if with_trend else 0.0
        mean_x, mean_y = sum(xs) / len(xs), sum(ys) / len(ys)
        total += sum(math.hypot(x - mean_x - trend * (t - mean_turn), y - mean_y) for t, x, y in zip(turns, xs, ys))
    return total / (68 * len(turns))


def parse_points(text):
    """'1-3,15-17' -> 0-based indices of those 1-based iBUG points."""
    indices = []
    for part in text.split(","):
        low, _, high = part.partition("-")
        try:
            first, last = int(low), int(high or low)
        except ValueError:
            sys.exit(f"--points: '{part}' is not a point or a range of points (1-68)")
        if not 1 <= first <= last <= 68:
            sys.exit(f"--points: '{part}' is not a point or a range of points (1-68)")
        indices.extend(range(first - 1, last))
    return indices


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("gt", help="folder of annotated images' .pts files")
    parser.add_argument("detections", nargs="+", help="`facesynth detect --out` folders")
    parser.add_argument("--write-offsets", metavar="FILE", help="with one DET folder: its mean (annotation - prediction) as label offsets")
    parser.add_argument("--points", metavar="LIST", help="also print the mean error over these 1-based points, e.g. 1-3,15-17")
    parser.add_argument("--turn-trend", action="store_true", help="also print the landmarks whose x offset changes with the head's turn")
    parser.add_argument("--jaw-directions", action="store_true", help="also print the jaw's mean error along its annotated outline and across it")
    parser.add_argument("--nme-csv", metavar="FILE", help="per face, each folder's mean error over --points (or all 68), for tools/nme_bootstrap.py")
    args = parser.parse_args()
    points = parse_points(args.points) if args.points else None
    if args.write_offsets and len(args.detections) != 1:
        sys.exit("--write-offsets takes exactly one detection folder")
    truth = {os.path.basename(p)[:-4]: read_pts(p) for p in sorted(glob.glob(os.path.join(args.gt, "*.pts")))}
    if not truth:
        sys.exit(f"{args.gt}: no .pts files")
    found = []  # (folder, its best detection per face), in argument order (a folder may be given twice)
    for folder in args.detections:
        best = {}
        for name, gt in truth.items():
            for path in glob.glob(os.path.join(folder, glob.escape(name) + "_*.pts")):
                p = read_pts(path)
                error = sum(math.dist(a, b) for a, b in zip(p, gt)) / 68
                if name not in best or error < best[name][0]:
                    best[name] = (error, p)
        found.append((folder, best))
    common = sorted(set.intersection(*(set(b) for _, b in found)))
    print(f"{len(common)} of {len(truth)} faces found in every folder")
    if not common:
        sys.exit("no face was found in every folder (do they hold `facesynth detect` output for these images?)")
    per_face = {name: [] for name in common}  # --nme-csv: each folder's mean error over the chosen points
    chosen = points or list(range(68))
    for folder, best in found:
        errors = [0.0] * 68
        turns, x_offsets, y_offsets = [], [], []  # per face: eye asymmetry, per landmark x and y offsets
        jaw_along = jaw_across = 0.0  # summed over faces and the 17 jaw points, inter-ocular
        for name in common:
            gt, p = truth[name], best[name][1]
            iod = math.dist(gt[36], gt[45])
            left, right = mean_of(gt, range(36, 42)), mean_of(gt, range(42, 48))
            norm = math.dist(left, right)
            ex = ((right[0] - left[0]) / norm, (right[1] - left[1]) / norm)
            ey = (-ex[1], ex[0])
            x_offsets.append([0.0] * 68)
            y_offsets.append([0.0] * 68)
            face_errors = [0.0] * 68
            for i in range(68):
                d = (p[i][0] - gt[i][0], p[i][1] - gt[i][1])
                face_errors[i] = math.hypot(*d) / iod
                errors[i] += face_errors[i]
                x_offsets[-1][i] = (d[0] * ex[0] + d[1] * ex[1]) / iod
                y_offsets[-1][i] = (d[0] * ey[0] + d[1] * ey[1]) / iod
            turns.append(eye_asymmetry(gt))
            if args.jaw_directions:
                along, across = jaw_directions(gt, p)
                jaw_along += along / iod
                jaw_across += across / iod
            per_face[name].append(sum(face_errors[i] for i in chosen) / len(chosen))
        n = len(common)
        offsets = [(sum(row[i] for row in x_offsets) / n, sum(row[i] for row in y_offsets) / n) for i in range(68)]
        groups = "  ".join(f"{g} {sum(errors[i] for i in r) / (n * len(r)):.4f}" for g, r in GROUPS.items())
        print(f"{folder}: mean {sum(errors) / (68 * n):.4f}  {groups}")
        if points:
            print(f"  points {args.points}: {sum(errors[i] for i in points) / (n * len(points)):.4f}")
        biased = [f"{i + 1}:{o[0]:+.3f},{o[1]:+.3f}" for i, o in enumerate(offsets) if math.hypot(*o) > 0.03]
        print("  offsets over 0.03 (x,y):", " ".join(biased) or "none")
        if args.turn_trend:
            slopes = [0.1 * slope(turns, [row[i] for row in x_offsets]) for i in range(68)]
            trending = [f"{i + 1}:{s:+.3f}" for i, s in enumerate(slopes) if abs(s) > 0.01]
            print("  x offset per 0.1 eye asymmetry, over 0.01:", " ".join(trending) or "none")
            print(f"  mean error with each landmark's mean offset taken off {bias_free_error(turns, x_offsets, y_offsets, False):.4f}, "
                  f"its turn trend too {bias_free_error(turns, x_offsets, y_offsets, True):.4f} (fitted on these faces: a bound)")
        if args.jaw_directions:
            print(f"  jaw along its outline {jaw_along / (17 * n):.4f}, across it {jaw_across / (17 * n):.4f}")
        if args.write_offsets:
            written = {"faces": n}
            for i, o in enumerate(offsets):
                written[f"mean_x_{i + 1:02d}"] = -o[0]
                written[f"mean_y_{i + 1:02d}"] = -o[1]
            with open(args.write_offsets, "w") as f:
                json.dump(written, f, indent=1)
                f.write("\n")
    if args.nme_csv:
        with open(args.nme_csv, "w") as f:
            f.write("key,yaw_deg,detected,view," + ",".join(f"regressor{k + 1}" for k in range(len(args.detections))) + "\n")
            for name in common:
                f.write(f"{name},,1," + "," + ",".join(f"{e:.6g}" for e in per_face[name]) + "\n")


if __name__ == "__main__":
    main()
