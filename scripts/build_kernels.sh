#!/usr/bin/env bash
# Builds the kernels (the `kernels` crate, with rust-gpu) into the committed SPIR-V folder that
# `vulkan-backend` embeds, or checks that folder against a fresh build.
#
#   scripts/build_kernels.sh           rebuild vulkan-backend/spirv (commit it with the sources)
#   scripts/build_kernels.sh --check   build afresh and exit 1 unless vulkan-backend/spirv holds
#                                      exactly those bytes (CI: scripts/test.sh)
#
# Through kernel-builder's test `committed_kernels` with the workspace's features, so the
# workspace's test build reuses its rust-gpu backend. The first run compiles rust-gpu's backend
# and SPIRV-Tools (about 12 minutes on 2 cores); each run compiles the kernels and optimizes
# their modules (about 15 minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  --check) write=0 ;;
  "") write=1 ;;
  *) echo "usage: $0 [--check]" >&2; exit 2 ;;
esac
# rust-gpu builds against the compiler's own crates and rebuilds `core` for SPIR-V.
rustup component add rust-src rustc-dev llvm-tools
JK_WRITE_KERNELS="$write" cargo test --workspace --release --test committed_kernels -- \
  --ignored --nocapture
