#!/usr/bin/env bash
# Installs the Debian 12 packages fleetslam needs, skipping those already installed. Non-interactive
# (CI has no terminal). Uses sudo when not run as root.
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build pkg-config ccache git
  # core
  libeigen3-dev libopencv-dev libyaml-cpp-dev libspdlog-dev nlohmann-json3-dev
  # tools and tests
  libcli11-dev libgtest-dev libgmock-dev
  # sim (MuJoCo 2.2 rendering off-screen through OSMesa)
  libmujoco-dev libosmesa6-dev libqhull-dev  # mujocoConfig.cmake names libqhull_r headers
  # slam (bundle adjustment, pose optimisation)
  libceres-dev
  # central (map merging: PCL's GICP as the comparison backend)
  libpcl-dev
  # planners (OMPL sampling-based planners on the fused map)
  libompl-dev
  # run reports: the tests look at report.html in a real headless browser
  chromium
)

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$package")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install_deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install_deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -q
$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
