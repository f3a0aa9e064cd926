#!/bin/sh
# The C++ compiler launcher of the build (CMakeLists.txt, PLAB_CCACHE):
#   sh ccache-launcher.sh SOURCE_ROOT COMPILER ARGS...   (by sh: no execute bit needed in a zip)
# runs the compiler through ccache, with the paths inside SOURCE_ROOT made relative (so that two
# copies of the kit share cached objects), where ccache is installed and its cache folder can be
# written; otherwise (a read-only home, a sandbox, no ccache) the compiler itself, unchanged.
# Debug information (the sanitizer builds' -g) names SOURCE_ROOT as "." (-ffile-prefix-map), so
# that an object does not depend on the copy's folder and ccache need not hash the build folder
# (CCACHE_NOHASHDIR): a clean clone's ASan and TSan builds then hit the cache as its release build
# does (CI's ASan step took 814 s from a cold cache on its 2-core machine). A sanitizer's report
# names a file as build-NAME/../path/in/the/kit, which reads from the copy's root.
root="$1"
shift
cache="${CCACHE_DIR:-${XDG_CACHE_HOME:-${HOME:-/nonexistent}/.cache}/ccache}"
if command -v ccache >/dev/null 2>&1 && mkdir -p "$cache" 2>/dev/null && [ -w "$cache" ]; then
  CCACHE_BASEDIR="$root" CCACHE_DIR="$cache" CCACHE_NOHASHDIR=1 exec ccache "$@" \
    "-ffile-prefix-map=$root=."
fi
exec "$@"
