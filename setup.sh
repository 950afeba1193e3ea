#!/usr/bin/env bash
# Installs roadsurvey's build and test dependencies from Debian 12 packages.
# Idempotent: installs only what is missing and prints nothing when all is present.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libopencv-dev libopencv-contrib-dev
  libeigen3-dev libceres-dev libpcl-dev
  libgeographiclib-dev libopenmesh-dev
  libproj-dev proj-data proj-bin
  nlohmann-json3-dev libvalijson-dev libcli11-dev
  libspdlog-dev libfmt-dev libtbb-dev libxxhash-dev libhwy-dev
  libpugixml-dev libyaml-cpp-dev
  libgtest-dev libgmock-dev
  clang libclang-rt-14-dev
  colmap
  libtiff-dev libgeotiff-dev
  gdal-bin
  libjs-leaflet chromium
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
# The report's browser test runs on Node.js with npm; a machine that already has them (from Debian or
# from NodeSource) keeps its own: Debian's npm package conflicts with NodeSource's nodejs.
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)
[ ${#missing[@]} -eq 0 ] && exit 0

echo "setup: installing ${#missing[@]} missing package(s): ${missing[*]}"
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
