#!/usr/bin/env bash
# Installs everything dvsgi needs on Debian 12 / Ubuntu 22.04+ (run as root or with sudo):
# the Vulkan loader, lavapipe (CPU Vulkan), the Khronos validation layer, vulkaninfo, and the
# shaderc/glslang/SPIRV-Tools static libraries that build.rs compiles the GLSL with.
# A Rust toolchain (rustup, 1.80 or newer) must already be installed.
set -euo pipefail

packages=(
  mesa-vulkan-drivers libvulkan1 libvulkan-dev vulkan-validationlayers vulkan-tools
  libshaderc-dev glslang-dev spirv-tools
  build-essential pkg-config
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found: install Rust 1.80+ with rustup (https://rustup.rs), then re-run" >&2
  exit 1
fi
echo "setup: ok ($(cargo --version))"
