#!/usr/bin/env bash
# Installs the Debian packages glintlab builds and tests with. Idempotent: packages already present are
# skipped, and `apt-get update` runs at most once, only when something is missing.
set -euo pipefail

PACKAGES=(
  build-essential cmake
  libeigen3-dev libboost-dev nlohmann-json3-dev catch2 librandom123-dev
  pybind11-dev python3-dev python3-venv python3-pybind11
  python3-numpy python3-scipy python3-matplotlib python3-pandas python3-pytest python3-tqdm
  python3-rich python3-mpmath python3-dask python3-distributed python3-nbclient python3-nbformat python3-ipykernel
  python3-jsonschema
  # make docs: the Sphinx API reference, Markdown pages (MyST) and the notebooks (docs/conf.py);
  # nbsphinx converts the notebooks' Markdown cells with pandoc (only a Recommends of nbconvert); the
  # furo theme
  python3-sphinx python3-myst-parser python3-nbsphinx pandoc furo
  # the report tests render index.html and the image viewer headless (tests/python/test_report.py,
  # test_viewer.py)
  chromium
  # make fuzz: clang with libFuzzer (libclang_rt.fuzzer-x86_64.a is in libclang-rt-14-dev) and
  # clang's OpenMP, which the top-level CMakeLists needs when configured with clang
  clang libclang-rt-14-dev libomp-dev
  # shader laws: shaderc compiles HLSL/GLSL to SPIR-V in-process, the Vulkan loader, and lavapipe
  # (mesa-vulkan-drivers) as the headless CPU device every machine has; spirv-tools and glslang-dev (a
  # dependency of libshaderc-dev) for their static libraries, which glintlab_shader links: Debian 12's
  # libshaderc.so.1 does not load against its own libSPIRV-Tools
  libshaderc-dev libvulkan-dev mesa-vulkan-drivers spirv-tools glslang-tools
  # SIMD math for the per-sample paths: SLEEF (vector exp/log/expm1/log1p) and Highway (dispatch)
  libsleef-dev libhwy-dev
  # property-based tests of the public API
  python3-hypothesis
  # the linters make test runs: flake8 for Python (.flake8; "lint: flake8") and clang-format for C++
  # (.clang-format; "lint: clang-format")
  flake8 clang-format
  # images: the print panel and the viewer's animated WebP (Pillow); matplotlib's animations (ffmpeg)
  python3-pil ffmpeg
  # textures from image files (glintlab shader|sampler|images --texture NAME=FILE): PNG through Pillow
  # (above), OpenEXR (float textures: noise, tables) through OpenImageIO's Python module
  python3-openimageio
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
