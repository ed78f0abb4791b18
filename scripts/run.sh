#!/usr/bin/env bash
# Fabrica's set-up-and-run entry point (the two commands of the README).
#   bash scripts/run.sh demo   install what is missing, build, run the built-in demo scene, plot
#   bash scripts/run.sh test   install what is missing (with ParaView and Chromium for the output
#                              checks), build, run the whole test suite (ctest)
# Works on a fresh Debian 12 machine as root (or with sudo); quick when everything is present.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-}
case "$mode" in demo|test) ;; *) echo "usage: bash scripts/run.sh demo|test" >&2; exit 2 ;; esac

packages=(build-essential cmake pkg-config openmpi-bin libopenmpi-dev libeigen3-dev
  libhdf5-openmpi-dev libmetis-dev libgtest-dev libgmock-dev libbenchmark-dev
  libtomlplusplus-dev libcli11-dev libfmt-dev python3 python3-numpy python3-matplotlib python3-h5py)
# The test suite also opens the XDMF sidecars in ParaView (pvpython, rendering under Xvfb) and the
# report page in headless Chromium (cli.output.paraview*, cli.report.html). On a fresh Debian 12
# machine these add about 270 MB of downloads and 1.2 GB on disk, 2-3 minutes (docs/output.md).
if [ "$mode" = test ]; then
  packages+=(paraview python3-paraview xvfb xauth chromium clang-format)  # clang-format: test style.clang_format
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing: ${missing[*]}"
  sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends "${missing[@]}"
fi

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
jobs=$(nproc)
echo "== building (Release) in build/"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$jobs"

if [ "$mode" = demo ]; then
  out=out/demo
  echo "== running the built-in demo scene (examples/demo.toml) on 2 MPI ranks into $out"
  mpirun --oversubscribe -np 2 build/apps/fabrica run -o "$out" --overwrite
  bash scripts/plot.sh "$out"   # the run's plotting step: out/demo/*.png, figures/, report.html
else
  echo "== running the test suite"
  # Every test removes what it writes (tests/temp_dir.hpp): the temporary directory is listed
  # before and after; a Fabrica file left there fails the run, anything else is reported.
  tmp=${TMPDIR:-/tmp}
  before=$(ls -A "$tmp" | sort)
  status=0
  ctest --test-dir build --output-on-failure -j"$jobs" || status=$?
  left=$(comm -13 <(printf '%s\n' "$before") <(ls -A "$tmp" | sort))
  if [ -n "$left" ]; then
    echo "== new in $tmp after the test suite:"
    printf '%s\n' "$left"
    if grep -qi fabrica <<<"$left"; then echo "== a test left files in $tmp"; status=1; fi
  fi
  exit $status
fi
