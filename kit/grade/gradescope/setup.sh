#!/usr/bin/env bash
# Gradescope's setup.sh for particle-lab: Gradescope runs it once, as root, when it builds the
# autograder's image, in /autograder/source (where it unpacked the autograder zip: this file,
# run_autograder and the instructor's kit, solutions included). It
#   1. installs the Debian packages the kit needs, calling apt-get only when one is missing (so it
#      also works offline on an image that has them all),
#   2. configures and builds the kit (`./plab --help`: the CLI, the reference solutions' programs),
#   3. makes the kit private to root: where the grader cannot use namespaces it runs student code
#      as an unprivileged user, which must not read the solutions or the grader.
# Made by `./plab gradescope --out autograder.zip` from kit/grade/gradescope/setup.sh.
set -euo pipefail
source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"   # /autograder/source on Gradescope
cd "$source_dir"

# The kit's Debian packages (the ./plab script's list, bubblewrap for the grader's sandbox).
packages=(cmake g++ ninja-build libgtest-dev libcli11-dev nlohmann-json3-dev doxygen graphviz
          bubblewrap clang libomp-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
# matplotlib (plab render, the docs' figures): Debian's package, unless the python3 on PATH
# already imports it.
python3 -c "import matplotlib, PIL" >/dev/null 2>&1 || missing+=(python3-matplotlib)
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup.sh: installing ${missing[*]}"
  apt-get update
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
else
  echo "setup.sh: every Debian package the kit needs is installed"
fi

# Configure (build/, CMake preset release; the CUDA stages only where nvcc is found) without the
# test suite, which grading does not use (half the build time), then build with ./plab.
# PLAB_CMAKE_ARGS, when set, adds CMake arguments (e.g. -DPLAB_ENABLE_CUDA=OFF).
if [ ! -f build/CMakeCache.txt ]; then
  # shellcheck disable=SC2086  # PLAB_CMAKE_ARGS is a list of words
  cmake --preset release -DPLAB_BUILD_TESTS=OFF ${PLAB_CMAKE_ARGS:-} >/dev/null
fi
./plab --help >/dev/null
echo "setup.sh: the kit is built in $source_dir/build"

# Nobody but root may read the kit (solutions, hidden-scene parameters, the grader).
chmod -R go-rwx "$source_dir"
echo "setup.sh: $source_dir is readable by root only"
