#!/usr/bin/env python3
"""Update the built-in model's annotator shifts (morph/builtin.cpp) from a conventions study.

    facesynth eval conventions --photos HELEN_TRAIN --json conv.json -q
    tools/landmark_conventions.py conv.json morph/builtin.cpp [--write]

The study holds, per landmark, the mean of (annotation - fitted model point) in the face frame, in
inter-ocular distances (x to the image right, y down). Each shift of the subject's right side and the
midline moves by that mean, symmetrised with the mirrored point and converted to model mm (x towards
the subject's left, y up). Rebuild, run the study again and repeat until the residuals stop falling:
moving one point changes the fit, and with it every other residual. The jaw, the lids and the outer lips are not touched (see MIRROR).
"""
import argparse
import json
import re
import sys

# Subject's right side -> mirrored left id (1-based iBUG), and the midline: the points whose place is a
# convention (brows, nose, eye and mouth corners, inner lips). The lid points and the outer lips' points
# stay on the lid margins and the vermilion border that define them (their residuals were within 0.02
# inter-ocular distances before any shift), and the jaw (1-17) on the outline.
MIRROR = {18: 27, 19: 26, 20: 25, 21: 24, 22: 23, 32: 36, 33: 35, 37: 46, 40: 43, 49: 55, 61: 65, 62: 64, 68: 66}
MIDLINE = [28, 29, 30, 31, 34, 63, 67]
# The inner lips stay on the rows beside the mouth line in y: a shift of a millimetre or two there
# jumps between the lips' surfaces, and the residual flips sign from one round to the next.
X_ONLY = {61, 62, 63, 67, 68}
BLOCK = re.compile(r"(// BEGIN annotator shifts[^\n]*\n)(.*?)(// END annotator shifts)", re.S)
ENTRY = re.compile(r"\{(\d+),\s*([-+0-9.eE]+),\s*([-+0-9.eE]+)\}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("conventions", help="JSON written by `facesynth eval conventions --json`")
    parser.add_argument("source", help="morph/builtin.cpp")
    parser.add_argument("--iod-mm", type=float, default=89.5, help="the mean face's inter-ocular distance (ex-ex), mm")
    parser.add_argument("--step", type=float, default=1.0, help="fraction of the residual to add")
    parser.add_argument("--write", action="store_true", help="rewrite the block in SOURCE (else print it)")
    args = parser.parse_args()

    with open(args.conventions) as f:
        study = json.load(f)
    try:
        mean = {i: (float(study[f"mean_x_{i:02d}"]), float(study[f"mean_y_{i:02d}"])) for i in range(1, 69)}
    except KeyError as e:
        sys.exit(f"{args.conventions}: missing key {e}")
    with open(args.source) as f:
        source = f.read()
    block = BLOCK.search(source)
    if not block:
        sys.exit(f"{args.source}: no '// BEGIN annotator shifts' ... '// END annotator shifts' block")
    shifts = {int(i): [float(x), float(y)] for i, x, y in ENTRY.findall(block.group(2)) if int(i) in MIRROR or int(i) in MIDLINE}
    for i in X_ONLY:
        if i in shifts:
            shifts[i][1] = 0.0

    for right, left in MIRROR.items():
        dx = 0.5 * (mean[right][0] - mean[left][0])
        dy = 0.5 * (mean[right][1] + mean[left][1])
        s = shifts.setdefault(right, [0.0, 0.0])
        s[0] += args.step * dx * args.iod_mm
        if right not in X_ONLY:
            s[1] -= args.step * dy * args.iod_mm
    for mid in MIDLINE:
        s = shifts.setdefault(mid, [0.0, 0.0])
        if mid not in X_ONLY:
            s[1] -= args.step * mean[mid][1] * args.iod_mm

    rows = [f"    {{{i}, {x:.1f}, {y:.1f}}}," for i, (x, y) in sorted(shifts.items())]
    table = f"constexpr std::array<AnnotatorShift, {len(rows)}> kAnnotatorShifts{{{{\n" + "\n".join(rows) + "\n}};\n"
    residual = sum(abs(v[0]) + abs(v[1]) for i, v in mean.items() if i > 17) / (68 - 17)
    print(f"mean |residual| over points 18-68: {residual:.4f} IOD", file=sys.stderr)
    if args.write:
        with open(args.source, "w") as f:
            f.write(source[: block.start(2)] + table + source[block.end(2):])
    else:
        print(table, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
