#!/usr/bin/env bash
# Configures and builds one CMake preset (default: release) into build/<preset>/.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
# ccache (when CMake found it): paths relative to the checkout, so that another clone of the same
# sources hits the same cache entries; the cache itself stays in ccache's default folder.
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"
