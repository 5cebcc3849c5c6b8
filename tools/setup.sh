#!/usr/bin/env bash
# Installs everything dvsgi needs on Debian 12 / Ubuntu 22.04+ (run as root or with sudo):
# the Vulkan loader, lavapipe (CPU Vulkan), the Khronos validation layer, vulkaninfo, and the
# shaderc/glslang/SPIRV-Tools static libraries that build.rs compiles the GLSL with, and for
# `dvsgi view`'s tests a virtual X display (Xvfb, xvfb-run) with the X libraries winit opens.
# A Rust toolchain (rustup, 1.80 or newer) must already be installed.
#
# lavapipe must be Mesa 25 or newer: it brings sparse residency (the sparse voxel volumes),
# ray queries and acceleration structures, which the tests exercise. Debian 12 ships Mesa 22.3,
# so on Debian 12 the script adds Debian's bookworm-backports suite and takes Mesa from there;
# Ubuntu 24.04+ and Debian 13 ship a recent Mesa already.
set -euo pipefail

packages=(
  mesa-vulkan-drivers libvulkan1 libvulkan-dev vulkan-validationlayers vulkan-tools
  libshaderc-dev glslang-dev spirv-tools
  build-essential pkg-config
  xvfb xauth libx11-xcb1 libxkbcommon-x11-0 libxcursor1 libxrandr2 libxi6
)

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
codename="$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")"

# mesa_major: the installed lavapipe's Mesa major version (0 when none).
mesa_major() {
  local v
  v="$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | sed -nE 's/^([0-9]+:)?([0-9]+).*/\2/p')"
  echo "${v:-0}"
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if [ "$(mesa_major)" -lt 25 ] && [ "$codename" = bookworm ]; then
  list=/etc/apt/sources.list.d/bookworm-backports.list
  if ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
    echo "setup: adding Debian's bookworm-backports suite ($list) for Mesa 25"
    echo "deb http://deb.debian.org/debian bookworm-backports main" | $sudo tee "$list" >/dev/null
  fi
  echo "setup: installing lavapipe (mesa-vulkan-drivers) from bookworm-backports"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
    -t bookworm-backports mesa-vulkan-drivers
fi
if [ "$(mesa_major)" -lt 25 ]; then
  echo "setup: warning: lavapipe is Mesa $(mesa_major), older than 25: no sparse residency or ray" \
    "queries on the CPU device, so the tests of the sparse voxel volumes and ray-traced" \
    "reflections fall back or are refused (install Mesa 25+ from your distribution)" >&2
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found: install Rust 1.80+ with rustup (https://rustup.rs), then re-run" >&2
  exit 1
fi
echo "setup: ok ($(cargo --version))"
