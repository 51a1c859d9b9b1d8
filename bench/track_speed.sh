#!/usr/bin/env bash
# Tracking speed on one core (docs/track.md, "Speed"): a rendered 640x480 clip and, when the shared
# data is there, the real 640x360 clip, each tracked (dlib's detector every 5 frames) and detected per
# frame, pinned to one core with taskset. Decoding is measured apart (decode_ms_per_frame).
#   bench/track_speed.sh [BUILD_DIR] [WORK_DIR]
set -euo pipefail
build=${1:-build}
work=${2:-$(mktemp -d)}
cli=$build/facesynth
data=${FACESYNTH_DATA:-$(dirname "$0")/../../shared/data}
mkdir -p "$work"
[[ -d $work/clip ]] || "$cli" synth -q -o "$work/clip" -n 150 --sequence 150 --size 640x480 --seed 11 --set pose.yaw.min=-30 --set pose.yaw.max=30
inputs=("$work/clip/images")
[[ -f $data/video/short_hamilton_clip.mp4 ]] && inputs+=("$data/video/short_hamilton_clip.mp4")
printf '%-40s %-10s %8s %8s %10s %11s %9s\n' input variant fps ms/frame decode_ms texture_ms detector
for input in "${inputs[@]}"; do
    for variant in tracked textures per-frame; do
        out=$work/out-$variant-$(basename "$input")
        rm -rf "$out"
        flags=(--detector dlib -q --json "$out.json")
        [[ $variant == per-frame ]] && flags+=(--per-frame)
        [[ $variant == textures ]] && flags+=(--outputs landmarks,pose,isomap,frontal)
        OPENCV_FOR_THREADS_NUM=1 taskset -c 0 "$cli" track "$input" -o "$out" "${flags[@]}"
        python3 - "$out.json" "$input" "$variant" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print(f"{sys.argv[2][-40:]:<40} {sys.argv[3]:<10} {j['fps']:8.1f} {j['ms_per_frame']:8.2f} {j['decode_ms_per_frame']:10.2f} "
      f"{j['texture_ms_per_frame']:11.2f} {j['detector_runs']:9d}")
PY
    done
done
