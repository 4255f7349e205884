#!/usr/bin/env bash
# Installs the Debian packages aoscan needs, and the npm packages of the service's web page
# (src/serve/web, from its lock file). Usage: tools/install-deps.sh [--tests] [--fuzz]
# --tests adds the test suite's packages (and the browser test's chromium and playwright-core),
# --fuzz clang and libFuzzer (tools/fuzz.sh).
# Uses sudo only when not root; does nothing when everything is already installed.
set -euo pipefail

packages=(build-essential cmake pkg-config libeigen3-dev libpng-dev libdeflate-dev libspdlog-dev libcli11-dev
          nlohmann-json3-dev libyaml-cpp-dev libtbb-dev
          libopenvdb-dev libboost-iostreams-dev     # volume.vdb (--save-volume)
          libtinyxml2-dev                            # MeshLab projects (aoscan scans)
          libopencv-imgcodecs-dev libopencv-imgproc-dev  # colour images; the colour registration
          libtinygltf-dev                            # mesh.glb
          libopenmpi-dev openmpi-bin                 # MPI ranks of aoscan scans (mpirun)
          libopenni2-dev libfreenect-dev             # live cameras (libusb comes with libfreenect)
          libglfw3-dev libglm-dev libgl-dev          # live view: GLFW window, GLM, GL headers
          libx11-dev libxrandr-dev                   # live view: surviving a lost X display (glfw3native.h)
          libcivetweb-dev)                           # aoscan serve: HTTP and WebSocket server
web="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/src/serve/web"
npm_packages=(three)  # the web page's (embedded in the binary at build time)
npm_omit=(--omit=dev)
for arg in "$@"; do
  case "$arg" in
    --tests)  # The GL tests run on a virtual X server with Mesa's software OpenGL; the browser
              # test drives Debian's chromium with playwright-core.
      packages+=(libgtest-dev xvfb xauth libgl1-mesa-dri libegl-mesa0 libglx-mesa0 chromium)
      npm_packages+=(playwright-core)
      npm_omit=() ;;
    --fuzz)  # clang 14 and its runtime libraries (libFuzzer, ASan, UBSan)
      packages+=(clang libclang-rt-14-dev) ;;
    *) echo "usage: tools/install-deps.sh [--tests] [--fuzz]" >&2; exit 2 ;;
  esac
done

command -v npm > /dev/null || packages+=(nodejs npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
npm_missing=0
for p in "${npm_packages[@]}"; do
  [[ -f "$web/node_modules/$p/package.json" ]] || npm_missing=1
done
if [[ ${#missing[@]} -eq 0 && $npm_missing -eq 0 ]]; then
  exit 0
fi

sudo=""
if [[ "$(id -u)" -ne 0 ]]; then
  sudo="sudo"
fi
if [[ ${#missing[@]} -gt 0 ]]; then
  echo "Installing: ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
if [[ $npm_missing -ne 0 ]]; then
  echo "Installing the web page's npm packages (src/serve/web/package-lock.json)"
  npm ci --prefix "$web" --no-audit --no-fund ${npm_omit[@]+"${npm_omit[@]}"}
fi
