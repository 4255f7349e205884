#!/usr/bin/env bash
# Installs the Debian packages aoscan needs. Usage: tools/install-deps.sh [--tests] [--fuzz]
# --tests adds the test suite's packages, --fuzz clang and libFuzzer (tools/fuzz.sh).
# Uses sudo only when not root; does nothing when every package is already installed.
set -euo pipefail

packages=(build-essential cmake pkg-config libeigen3-dev libpng-dev libspdlog-dev libcli11-dev
          nlohmann-json3-dev libyaml-cpp-dev libtbb-dev
          libopenvdb-dev libboost-iostreams-dev     # volume.vdb (--save-volume)
          libtinyxml2-dev                            # MeshLab projects (aoscan scans)
          libopencv-imgcodecs-dev libopencv-imgproc-dev  # colour images; the colour registration
          libtinygltf-dev                            # mesh.glb
          libopenmpi-dev openmpi-bin                 # MPI ranks of aoscan scans (mpirun)
          libopenni2-dev libfreenect-dev             # live cameras (libusb comes with libfreenect)
          libglfw3-dev libglm-dev libgl-dev          # live view: GLFW window, GLM, GL headers
          libx11-dev libxrandr-dev)                  # live view: surviving a lost X display (glfw3native.h)
for arg in "$@"; do
  case "$arg" in
    --tests)  # The GL tests run on a virtual X server with Mesa's software OpenGL.
      packages+=(libgtest-dev xvfb xauth libgl1-mesa-dri libegl-mesa0 libglx-mesa0) ;;
    --fuzz)  # clang 14 and its runtime libraries (libFuzzer, ASan, UBSan)
      packages+=(clang libclang-rt-14-dev) ;;
    *) echo "usage: tools/install-deps.sh [--tests] [--fuzz]" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi

sudo=""
if [[ "$(id -u)" -ne 0 ]]; then
  sudo="sudo"
fi
echo "Installing: ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
