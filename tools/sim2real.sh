#!/usr/bin/env bash
# Trains a landmark regressor for real photographs on synthetic images only, with appearance taken from
# annotated photographs (docs/textures.md; figures in docs/results.md):
#   1. facesynth textures     a texture bank from the photographs, each texture with the shape and expression
#                             fitted to its photograph (a weak identity prior, --fit-lambda 3, so that the
#                             shape follows the annotated chin and outline), its features warped onto the fitted model's
#                             (--align-features; their labels are not training targets), hair and hands
#                             across the upper face filled from the other side (--drop-occluders), and the
#                             photograph's own light left in it (--keep-shading)
#   2. backgrounds            wallpapers (default): the photographs among Debian's wallpaper packages
#                             (background.type = wallpapers); photos: `facesynth backgrounds`, the
#                             photographs with their annotated face cut away
#   3. facesynth synth        COUNT renders (default 36000): each texture on its own photograph's fitted shape and
#                             expression, half of them mixed with a second texture's colour, on a whole head
#                             (neck, shoulders, clothing, hair; head.body) whose skin the face and chin shade
#                             (head.ambient_occlusion), the face under an even white light only (it keeps the
#                             photograph's light) and the head parts under one or two white directional lights
#                             with cast shadows and a soft environment (lighting.face_light = even), exposed
#                             for the face as photographs are (face grey level 0.49 ± 0.13), the backgrounds,
#                             the head turned as in the texture's photograph (pose.source = texture: yaw drawn
#                             around it with σ 21.6°, so that with the photographs' own 12.6° the yaws spread as
#                             a normal of σ 25°; pitch and roll within σ 1° of the photograph's), long lenses
#                             (fov 4-20°), degradations, and the jaw labels evenly spaced along the outline as
#                             annotators space them (landmarks.mode = even)
#                             (into WORK/seed-S/train for each seed S, replacing a set made with other settings)
#   4. facesynth train        the SDM regressor on those renders alone (3×3 HOG cells, 6 stages, --augment starts),
#                             with a 4-stage realigned cascade for `realign:MODEL`'s second pass (docs/results.md
#                             row 85). At 36000 renders on 2 cores the whole script took 61 minutes for row 75
#                             (renders 22, training 37, other work beside it for 20) and 7.4 GB; the realigned
#                             cascades add 33 minutes and take 8.7 GB; docs/results.md rows 55-85
#   5. facesynth train merge  with several seeds (default two: 101,202), steps 3 and 4 run once per seed and the
#                             models are joined into one ensemble file whose regressor averages their landmarks
#                             (docs/results.md row 91: afw 0.0541 against 0.0552 and 0.0542 for the seeds alone);
#                             each seed takes 1 h 40 min on 2 cores (row 89) and its renders 4.4 GB in WORK
# usage: tools/sim2real.sh --photos DIR --out MODEL.sdm [--count N] [--threads T] [--work DIR] [--seeds S1,S2,...]
#                          [--backgrounds wallpapers|photos] [--min-side PX]  (photo strips' shorter side, default 96)
#                          [--augment A]  (training starts per render, default 4)
#        tools/sim2real.sh --photos DIR --renders-only --work DIR [...]   steps 1-3 only: the renders in WORK/seed-S/train,
#                          no model (tools/joined.sh trains on them beside the photographs)
set -euo pipefail
photos="" out="" count=36000 threads=2 work="" seed_list=101,202 min_side=96 backgrounds=wallpapers augment=4 renders_only=0
while [[ $# -gt 0 ]]; do
    case $1 in
        --photos) photos=$2; shift 2 ;;
        --out) out=$2; shift 2 ;;
        --count) count=$2; shift 2 ;;
        --threads) threads=$2; shift 2 ;;
        --work) work=$2; shift 2 ;;
        --seeds) seed_list=$2; shift 2 ;;
        --min-side) min_side=$2; shift 2 ;;
        --backgrounds) backgrounds=$2; shift 2 ;;
        --augment) augment=$2; shift 2 ;;
        --renders-only) renders_only=1; shift ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1' "$0"; exit 0 ;;
        *) echo "sim2real: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done
if [[ $renders_only -eq 1 ]]; then
    [[ -n $photos && -n $work && -z $out ]] || { echo "sim2real: --renders-only takes --photos DIR and --work DIR, and no --out (see --help)" >&2; exit 2; }
else
    [[ -n $photos && -n $out ]] || { echo "sim2real: --photos DIR and --out MODEL are required (see --help)" >&2; exit 2; }
fi
[[ $backgrounds == wallpapers || $backgrounds == photos ]] || { echo "sim2real: --backgrounds takes wallpapers or photos" >&2; exit 2; }
[[ -d $photos ]] || { echo "sim2real: $photos: photo folder not found" >&2; exit 1; }
[[ $count =~ ^[1-9][0-9]*$ && $threads =~ ^[1-9][0-9]*$ && $min_side =~ ^[1-9][0-9]*$ && $augment =~ ^[1-9][0-9]*$ ]] ||
    { echo "sim2real: --count, --threads, --min-side and --augment take whole numbers" >&2; exit 2; }
[[ $seed_list =~ ^[0-9]+(,[0-9]+)*$ ]] || { echo "sim2real: --seeds takes whole numbers, comma-separated" >&2; exit 2; }
IFS=, read -r -a seeds <<< "$seed_list"
[[ $(printf '%s\n' "${seeds[@]}" | sort -u | wc -l) -eq ${#seeds[@]} ]] || { echo "sim2real: --seeds repeats a seed" >&2; exit 2; }
# Paths given relative to where the script was started from; the script then works from the checkout.
absolute() { [[ $1 == /* ]] && echo "$1" || echo "$PWD/$1"; }
photos=$(absolute "$photos")
[[ -z $out ]] || out=$(absolute "$out")
[[ -z $work ]] || work=$(absolute "$work")
[[ ${FACESYNTH:-} != */* ]] || FACESYNTH=$(absolute "$FACESYNTH")
cd "$(dirname "$0")/.."
facesynth=${FACESYNTH:-build/facesynth}
[[ -x $facesynth ]] || { echo "sim2real: $facesynth not found: build first (README) or set FACESYNTH" >&2; exit 1; }
work=${work:-$(dirname "$out")/sim2real-work}
mkdir -p "$work"
quiet=()
[[ -t 2 ]] || quiet=(-q)

# The bank is rebuilt every time (a minute for 870 photographs): one made by another build may be for
# another model or lack what synth now takes from it.
"$facesynth" textures --photos "$photos" --out "$work/bank" --align-features --drop-occluders --keep-shading --fit-lambda 3 --json "$work/textures.json" "${quiet[@]}"
background=(--set background.type=wallpapers)
if [[ $backgrounds == photos ]]; then
    [[ -d $work/backgrounds ]] || "$facesynth" backgrounds --photos "$photos" --out "$work/backgrounds" --min-side "$min_side" --json "$work/backgrounds.json" "${quiet[@]}"
    background=(--set background.type=images --set background.folder="$work/backgrounds")
fi
# One render set and one model per seed; several are joined into an ensemble whose regressor averages
# their landmarks (docs/results.md row 91: two seeds' models together gain on helen_val what neither
# seed's renders alone give).
members=()
for s in "${seeds[@]}"; do
    member_work="$work/seed-$s"
    member="$member_work/model.sdm"
    [[ ${#seeds[@]} -gt 1 ]] || member=$out
    mkdir -p "$member_work"
    "$facesynth" synth --out "$member_work/train" --overwrite --count "$count" --seed "$s" --threads "$threads" "${quiet[@]}" \
        --set pose.source=texture --set pose.yaw.distribution=normal --set pose.yaw.stddev=21.6 --set pose.yaw.min=-60 --set pose.yaw.max=60 \
        --set pose.pitch.distribution=normal --set pose.pitch.mean=0 --set pose.pitch.stddev=1 --set pose.roll.distribution=normal --set pose.roll.stddev=1 \
        --set albedo.texture_bank="$work/bank" --set identity.source=texture --set expression.source=texture --set albedo.texture_mix_probability=0.5 \
        --set head.body=true --set head.ambient_occlusion=1 \
        --set lighting.face_light=even --set lighting.directional_min=1 --set lighting.intensity_min=0.4 --set lighting.intensity_max=0.8 \
        --set lighting.shadow_probability=1 --set lighting.ambient_max=0 --set lighting.colour_temperature_min=6500 --set lighting.colour_temperature_max=6500 \
        --set lighting.face_luminance_mean=0.49 \
        --set camera.fov_min=4 --set camera.fov_max=20 --set landmarks.mode=even \
        "${background[@]}" \
        --set degrade.noise_probability=0.5 --set degrade.blur_probability=0.5 --set degrade.jpeg_probability=0.5 \
        --set degrade.downscale_probability=0.3 --set degrade.gamma_probability=0.5 --set degrade.colour_jitter_probability=0.5
    [[ $renders_only -eq 0 ]] || continue
    "$facesynth" train --data "$member_work/train" --out "$member" --hog-cells 3 --stages 6 --augment "$augment" --threads "$threads" --lambda-factors 3,10,30,100 --realign-stages 4 \
        --json "$member_work/train.json" $([[ ${#quiet[@]} -gt 0 ]] && echo --quiet)
    members+=("$member")
done
if [[ $renders_only -eq 1 ]]; then
    echo "sim2real: renders in $work/seed-*/train"
    exit 0
fi
[[ ${#seeds[@]} -eq 1 ]] || "$facesynth" train merge "${members[@]}" --out "$out" "${quiet[@]}"
echo "sim2real: $out (work files in $work)"
