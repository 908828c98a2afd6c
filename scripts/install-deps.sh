#!/usr/bin/env bash
# Installs the Debian (bookworm) packages projtour needs, only those missing.
set -euo pipefail
packages=(
  build-essential cmake pkg-config clang libclang-rt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libcpp-httplib-dev cyclonedds-dev cyclonedds-tools
  libsqlite3-dev libssl-dev
  libeigen3-dev libyaml-cpp-dev libopencv-dev libopencv-contrib-dev libpcl-dev libopenni2-dev
  libmrpt-poses-dev libmrpt-maps-dev libmrpt-slam-dev libmrpt-obs-dev
  libmrpt-config-dev libmrpt-kinematics-dev libmrpt-hwdrivers-dev mrpt-common
  libcgal-demo
  chromium
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "installing: ${missing[*]}"
sudo_cmd=""
[ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -qq
$sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
