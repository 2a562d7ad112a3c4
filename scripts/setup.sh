#!/usr/bin/env bash
# Kumite set-up on a fresh Debian 12 machine: install every Debian package the project
# needs, configure and build. Re-running is safe (apt-get and CMake are idempotent).
#
#   scripts/setup.sh            # packages + Release build in build/
#   SKIP_APT=1 scripts/setup.sh # build only (packages already there)
#   BUILD_DIR=build-x BUILD_TYPE=Debug scripts/setup.sh
set -euo pipefail
cd "$(dirname "$0")/.."

BUILD_DIR=${BUILD_DIR:-build}
BUILD_TYPE=${BUILD_TYPE:-RelWithDebInfo}

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config ccache clang libclang-rt-14-dev libfuzzer-14-dev
  # maths, vision, optimisation
  libeigen3-dev libglm-dev libopencv-dev libopencv-contrib-dev libapriltag-dev libceres-dev
  # config, CLI, logging, JSON; zlib (session recordings: the frames' states compressed);
  # libyaml (calibration files checked by it before OpenCV's FileStorage parser reads them)
  libtomlplusplus-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev zlib1g-dev libyaml-dev
  # lock-free queues (header-only boost::lockfree: pose samples to the recognition thread)
  libboost-dev
  # glTF 2.0 skinned bodies (body/): tinygltf, which needs stb (images) and nlohmann-json (above)
  libtinygltf-dev libstb-dev
  # graphics: windows, headless EGL (Mesa llvmpipe), operator console
  libglfw3-dev libegl-dev libgl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri libimgui-dev
  xvfb xauth
  # running as a service: sd_notify readiness and watchdog pings (systemd)
  libsystemd-dev
  # messaging (render cluster / OSC, later)
  libzmq3-dev cppzmq-dev liblo-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # offline training and plots of the learned strike recogniser (recognition/train; not needed to build)
  python3-torch python3-numpy python3-matplotlib
)

if [[ "${SKIP_APT:-0}" != 1 ]]; then
  SUDO=""
  if [[ $(id -u) != 0 ]]; then SUDO=sudo; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${PACKAGES[@]}"
fi

cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE" "$@"
cmake --build "$BUILD_DIR" -j"$(nproc)"

# Demo data the installation runs on (the fighter's database, a synthetic tracking
# recording), generated from files in the repo.
if [[ "${SKIP_DEMO_DATA:-0}" != 1 && -x scripts/make-demo-data.sh ]]; then
  scripts/make-demo-data.sh "$BUILD_DIR"
fi
