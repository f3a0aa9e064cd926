#!/bin/sh
# The C++ compiler launcher of the build (CMakeLists.txt, PLAB_CCACHE):
#   sh ccache-launcher.sh SOURCE_ROOT COMPILER ARGS...   (by sh: no execute bit needed in a zip)
# runs the compiler through ccache, with the paths inside SOURCE_ROOT made relative (so that two
# copies of the kit share cached objects), where ccache is installed and its cache folder can be
# written; otherwise (a read-only home, a sandbox, no ccache) the compiler itself, unchanged.
root="$1"
shift
cache="${CCACHE_DIR:-${XDG_CACHE_HOME:-${HOME:-/nonexistent}/.cache}/ccache}"
if command -v ccache >/dev/null 2>&1 && mkdir -p "$cache" 2>/dev/null && [ -w "$cache" ]; then
  CCACHE_BASEDIR="$root" CCACHE_DIR="$cache" exec ccache "$@"
fi
exec "$@"
