#!/usr/bin/env bash
# Runs the examples one after another, each on the previous one's output, and checks what they
# write: render a face, fit its landmarks, find it again with the face detector and dlib's
# predictor, and generate samples in memory.
#   run_examples.sh BIN_DIR WORK_DIR
set -euo pipefail
bin=$1 work=$2
rm -rf "$work" && mkdir -p "$work"

points_in() { sed -n '/{/,/}/p' "$1" | grep -c '^[-0-9.]* [-0-9.]*$'; }
fail() { echo "run_examples: $*" >&2; exit 1; }

"$bin/render_face" "$work/face" 7 0
[[ -s $work/face/image.png ]] || fail "render_face wrote no image"
[[ $(points_in "$work/face/image.pts") -eq 68 ]] || fail "render_face: image.pts does not hold 68 points"

"$bin/fit_pts" "$work/face/image.pts" "$work/fit.obj"
[[ $(grep -c '^v ' "$work/fit.obj") -gt 1000 ]] || fail "fit_pts: fit.obj has no mesh"

"$bin/detect_landmarks" "$work/face/image.png" "$work/found" dlib frontal
[[ $(points_in "$work/found_0.pts") -eq 68 ]] || fail "detect_landmarks: found_0.pts does not hold 68 points"
# The face found is the face rendered: mean error over the inter-ocular distance (iBUG 37-46).
nme=$(paste <(sed -n '/{/,/}/p' "$work/face/image.pts" | grep '^[-0-9]') <(sed -n '/{/,/}/p' "$work/found_0.pts" | grep '^[-0-9]') |
    awk '{ x[NR] = $1; y[NR] = $2; e += sqrt(($1 - $3) ^ 2 + ($2 - $4) ^ 2) }
         END { printf "%.4f", e / NR / sqrt((x[37] - x[46]) ^ 2 + (y[37] - y[46]) ^ 2) }')
awk -v nme="$nme" 'BEGIN { exit !(nme < 0.15) }' || fail "detect_landmarks: NME $nme against the rendered landmarks"
if "$bin/detect_landmarks" "$work/fit.obj" "$work/none" dlib frontal 2> "$work/error.txt"; then fail "detect_landmarks read an OBJ file as an image"; fi
grep -q "fit.obj: cannot read the image" "$work/error.txt" || fail "detect_landmarks: unclear error: $(cat "$work/error.txt")"

"$bin/dataset_in_memory" 3 5 camera.width=128 camera.height=128 > "$work/samples.txt"
[[ $(grep -c '^sample [0-2]: 128x128' "$work/samples.txt") -eq 3 ]] || fail "dataset_in_memory: $(cat "$work/samples.txt")"
echo "run_examples: all examples ran"
