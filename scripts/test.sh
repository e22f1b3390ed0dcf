#!/usr/bin/env bash
# Runs every test of the workspace on a fresh Debian machine: installs the apt packages the GPU
# tests need (lavapipe, the Vulkan loader, a C++ compiler for SPIRV-Tools, Xvfb and xdotool for
# the viewer), the browser of the
# `host report` test (chromium and chromedriver) and the pinned Rust toolchain, checks the
# committed kernels against a fresh rust-gpu build (when recent commits changed them), then
# `cargo test --workspace --release`, then the `jackknife` library crate on stable Rust. Extra
# arguments go to the workspace `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."

# xvfb and xdotool: host/tests/view.rs drives `host view` in a virtual X server.
packages=(mesa-vulkan-drivers libvulkan1 g++ xvfb xdotool)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# host/tests/report.rs opens the HTML viewer in headless Chromium through chromedriver.
if [ ! -x /usr/bin/chromium ] || [ ! -x /usr/bin/chromedriver ]; then
  missing+=(chromium chromium-driver)
fi
if ((${#missing[@]})); then
  echo "test.sh: installing ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}"
fi

# rustup does not auto-install on these machines: install what rust-toolchain.toml names.
rustup toolchain install

# The results pages' generated tables match their JSONs.
python3 scripts/results_check.py

# Every file, folder, link and Rust item the docs name exists.
python3 scripts/docs_check.py

# No crate's modules import each other in a cycle.
for src in shared/src host/src engine/src lab/src jackknife/src volume-io/src kernels/src output/src \
  studies/src vulkan-backend/src viewer/src kernel-builder/src; do
  python3 scripts/module_cycles.py "$src"
done

# The committed SPIR-V modules (vulkan-backend/spirv) are exactly what the sources build to:
# rust-gpu compiles the kernels afresh and the bytes are compared. That build takes about 25
# minutes cold on 2 cores, so it runs where a recent commit could have made a difference: when
# any of the last 25 commits changed the modules or what they are built from (or the history is
# shorter or absent, or JK_CHECK_KERNELS=1). Every build also hashes the sources and never embeds
# modules built from other ones (vulkan-backend/build.rs then builds the kernels afresh).
kernel_inputs=(vulkan-backend/spirv vulkan-backend/build shared kernels kernel-builder Cargo.toml
  Cargo.lock rust-toolchain.toml)
if [ "${JK_CHECK_KERNELS:-0}" = 1 ] || ! git rev-parse --verify -q HEAD~25 >/dev/null 2>&1 ||
  [ -n "$(git log -n 25 --format=%h -- "${kernel_inputs[@]}")" ]; then
  ./scripts/build_kernels.sh --check
else
  echo "test.sh: none of the last 25 commits changed the kernels or their modules; skipping the" \
    "fresh rust-gpu build that compares them (JK_CHECK_KERNELS=1 runs it)"
fi

cargo test --workspace --release "$@"

# The library face must build and pass its doc test on stable Rust, without rust-gpu: on the
# first installed toolchain that is not a nightly (`stable-...` or a release like `1.95.0-...`).
stable="$(rustup toolchain list | awk '{print $1}' | grep -v nightly | head -n 1)"
if [ -n "$stable" ]; then
  cargo "+$stable" test -p jackknife
else
  echo "test.sh: no stable toolchain installed; skipping the stable build of the jackknife crate" >&2
fi
