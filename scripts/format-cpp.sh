#!/usr/bin/env bash
# The project's C++ style (.clang-format). `scripts/format-cpp.sh` rewrites the files in place (make format);
# `scripts/format-cpp.sh --check [CLANG_FORMAT]` changes nothing and fails naming each file that differs
# (make test: "lint: clang-format"). The files: every C++ source, header and .inc fragment git tracks, less
# the shader bodies in python/glintlab/data/shaders (HLSL/GLSL, not C++).
set -euo pipefail
cd "$(dirname "$0")/.."
check=0
if [ "${1:-}" = "--check" ]; then check=1; shift; fi
clang_format=${1:-clang-format}
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' '*.inc' | grep -v '^python/glintlab/data/shaders/')
if [ "$check" = 1 ]; then
  "$clang_format" --dry-run --Werror "${files[@]}"
else
  "$clang_format" -i "${files[@]}"
fi
