#!/usr/bin/env bash
# Regenerates the volume-loader fixtures in tests/fixtures/ with OpenVDB and NanoVDB themselves
# (Debian 12: OpenVDB/NanoVDB 10.0.1), so the loader tests compare against files and values that
# our code did not write. Installs libopenvdb-dev, libnanovdb-tools and g++ with apt if missing.
# The fixtures are checked into git; run this only to regenerate them.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(libopenvdb-dev libboost-dev libnanovdb-tools g++)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "make_fixtures.sh: installing ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}"
fi

out=tests/fixtures
build=$(mktemp -d)
trap 'rm -rf "$build"' EXIT
mkdir -p "$out"
# The fixtures of scripts/make_sparse_volumes.py are not written here: keep them.
find "$out" -maxdepth 1 \( -name '*.vdb' -o -name '*.nvdb' -o -name '*.expected' \) \
  ! -name 'sparse_patches.*' ! -name two_far.vdb ! -name wide.vdb -delete

echo "make_fixtures.sh: compiling scripts/make_fixtures.cpp"
g++ -std=c++17 -O1 -o "$build/make_fixtures" scripts/make_fixtures.cpp -lopenvdb -ltbb -lImath-3_1
"$build/make_fixtures" "$out"

# NanoVDB versions of some of them, converted by NanoVDB's own tool. ZIP-compressed (-z): an
# uncompressed .nvdb holds at least one dense 32^3 upper node table (> 256 KiB).
nvdb() { nanovdb_convert -f "$@" >/dev/null && echo "wrote ${*: -1}"; }
for name in density_blosc scale_translate affine tiles multi vec3 int; do
  nvdb -z "$out/$name.vdb" "$out/${name/_blosc/}.nvdb"
done
nvdb -b "$out/density_blosc.vdb" "$out/density_blosc.nvdb"
nvdb -z --fp16 "$out/density_blosc.vdb" "$out/density_fp16.nvdb"
# The sparse fixture (written by scripts/make_sparse_volumes.py fixture) as NanoVDB.
if [ -f "$out/sparse_patches.vdb" ]; then
  nvdb -z "$out/sparse_patches.vdb" "$out/sparse_patches.nvdb"
fi

ls -l "$out"
