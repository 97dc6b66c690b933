#!/usr/bin/env bash
# Installs the Debian packages coloc builds and runs with. Idempotent: when every package is
# already installed it does nothing (no network, no apt-get update). Run as root (or with sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev
  libopencv-dev libopencv-contrib-dev
  libceres-dev libsuitesparse-dev
  libosmesa6-dev
  libsqlite3-dev sqlite3
  libpcl-dev
  liblo-dev liblo-tools
  libyaml-cpp-dev
  libspdlog-dev libcli11-dev libpugixml-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev stress-ng
  python3 python3-numpy python3-matplotlib
  libcpp-httplib-dev
  nodejs chromium chromium-driver
  mkdocs
  pcl-tools
  mono-devel nunit-console
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# npm: Debian's package, unless a nodejs from elsewhere (NodeSource) already brings its own npm
# (Debian's npm package would conflict with it).
if ! command -v npm >/dev/null; then
  missing+=(npm)
fi

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install_deps: all ${#packages[@]} packages present" >&2
  exit 0
fi

echo "install_deps: installing ${#missing[@]} packages: ${missing[*]}" >&2
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install_deps: done" >&2
