#!/usr/bin/env bash
# Installs Runout's build and test dependencies from Debian 12's packages. Idempotent: packages already
# present are skipped by apt; run as root (or with sudo available).
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libeigen3-dev
  libgdal-dev gdal-bin
  libcpp-httplib-dev
  libboost-dev  # Boost.Beast and Asio, header-only: the service's HTTP front end (docs/service.md)
  libsqlite3-dev sqlite3 libssl-dev
  libpng-dev  # the web map's coloured rasters (scenarios/src/raster_map.cpp)
  libgtest-dev  # GoogleTest only: no test uses gmock, and bench/ times with its own loops, not Google Benchmark
  nlohmann-json3-dev libcli11-dev libspdlog-dev
  python-matplotlib-data
  chromium
  libopenmpi-dev openmpi-bin  # optional for the build: sweeps over MPI ranks (docs/cluster.md)
  qgis python3-qgis python3-gdal  # qgis_process and PyQGIS: the QGIS provider's headless test and picture (docs/qgis.md)
)
# The web page (web/, docs/web.md) is built with npm and its browser test runs under Node. Node 20 and npm
# come with the machine (NodeSource); Debian's own nodejs/npm are installed only where `node`/`npm` are missing
# (Debian's npm conflicts with NodeSource's nodejs).
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: installed ${missing[*]}"
