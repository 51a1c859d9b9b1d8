#!/usr/bin/env bash
# Installs the Debian 12 packages facesynth builds and runs with, only those that are missing.
# Safe to run any number of times. Needs root or sudo.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git clang-tidy ccache
  libeigen3-dev libceres-dev
  libopencv-dev libopencv-contrib-dev opencv-data
  libegl-dev libegl1 libegl-mesa0 libgl1-mesa-dri libgl-dev libgles-dev libosmesa6-dev libgbm-dev
  libglm-dev libtinygltf-dev libopenexr-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libtoml11-dev libspdlog-dev libfmt-dev
  libarchive-dev libdeflate-dev libhdf5-dev libpng-dev
  libdlib-dev libdlib-data
  pybind11-dev python3-dev python3-numpy python3-pytest
  mate-backgrounds plasma-workspace-wallpapers lomiri-wallpapers-16.04
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${#missing[@]} missing packages: ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
