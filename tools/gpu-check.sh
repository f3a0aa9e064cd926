#!/usr/bin/env bash
# Builds particle-lab with its CUDA stages on a machine with a GPU, runs every GPU test (golden
# files of every dataset, the large ones too; the same text as the CPU stages on fresh scenes) and
# times stages 03, 04 and 05 on the 2019 report's scenes. Needs no network and no Doxygen: only
# cmake, ninja, g++, nvcc, GoogleTest, CLI11 and nlohmann-json.
#
#   tools/gpu-check.sh [RESULTS_DIR]      (default build-gpu/results)
#   PLAB_CUDA_ARCH=80 tools/gpu-check.sh  (another GPU than an H100)
#   PLAB_BENCH_N=1000,10000 PLAB_BENCH_RUNS=3 tools/gpu-check.sh   (a shorter benchmark)
#   PLAB_SKIP_REDTEAM=1 PLAB_SKIP_ABLATION=1 tools/gpu-check.sh   (without the grader's GPU
#                                          idea tests, or without stage 05's ablation)
set -euo pipefail
cd "$(dirname "$0")/.."
results=${1:-build-gpu/results}
mkdir -p "$results"
log() { printf '\n== %s\n' "$*"; }

log "device"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | tee "$results/device.txt"

log "configure and build (CUDA architectures ${PLAB_CUDA_ARCH:-90}, --fmad=false)"
cmake -S . -B build-gpu -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CUDA_ARCHITECTURES="${PLAB_CUDA_ARCH:-90}" > "$results/configure.log"
cmake --build build-gpu -j "$(nproc)" > "$results/build.log" 2>&1 || { tail -40 "$results/build.log"; exit 1; }
echo "built"

log "GPU tests (ctest -L gpu: the solutions, large scenes included, and the starting points)"
status=0
ctest --test-dir build-gpu -L gpu -LE '^student$' -j 4 --output-on-failure > "$results/ctest-gpu.log" 2>&1 || status=1
tail -25 "$results/ctest-gpu.log"

log "stage 06 forced onto the CPU (PLAB_DEVICE=cpu): the same tests"
PLAB_DEVICE=cpu ctest --test-dir build-gpu -R '^stage06[.]solution' -LE long -j 4 \
    > "$results/ctest-06-cpu.log" 2>&1 || status=1
tail -3 "$results/ctest-06-cpu.log"

log "benchmark: stages ${PLAB_BENCH_STAGES:-03,04,05,06} (CPU stages on $(nproc) threads); L = 20000, r = 1, S = 500"
build-gpu/bin/plab bench --stage "${PLAB_BENCH_STAGES:-03,04,05,06}" --threads "$(nproc)" --steps 500 \
    --n "${PLAB_BENCH_N:-1000,2000,3000,4000,5000,6000,7000,8000,9000,10000}" \
    --runs "${PLAB_BENCH_RUNS:-3}" --csv "$results/bench-gpu.csv"

log "compute-sanitizer memcheck: each GPU program on course-1 (the lab solutions and the engine)"
for prog in plab-run-04-solution plab-run-05-solution plab-run-06-solution plab-run-06-engine; do
  if [ -x "build-gpu/bin/$prog" ]; then
    compute-sanitizer --tool memcheck --error-exitcode 9 "build-gpu/bin/$prog" --device gpu \
        datasets/scenes/course-1.in --quiet --out /dev/null > "$results/memcheck-$prog.log" 2>&1 \
      && echo "$prog: memcheck clean" || { echo "$prog: MEMCHECK FAILED"; tail -5 "$results/memcheck-$prog.log"; status=1; }
  fi
done

log "stage 06's engine on the GPU against its CPU path in every mode of its small scenes' search and finish (tools/engine-modes.sh)"
if [ -x tools/engine-modes.sh ]; then  # (the kit's engine: not in a student copy)
  tools/engine-modes.sh build-gpu/bin gpu > "$results/engine-modes.log" 2>&1 || status=1
  cat "$results/engine-modes.log"
else
  echo "no tools/engine-modes.sh (a student copy): skipped"
fi

log "stage 06 at the report's density (L = 20000 sqrt(N / 10^4), speeds 2500..5000), S = 100: the lab solution and the kit's engine"
for impl in solution engine; do
  build-gpu/bin/plab bench --stage 06 --impl "$impl" --fixed-density --steps 100 --runs "${PLAB_BENCH_RUNS:-3}" \
      --n "${PLAB_SCALE_N:-10000,100000,1000000}" --csv "$results/bench-06-scale-$impl.csv"
done

if [ -z "${PLAB_SKIP_REDTEAM:-}" ] && [ ! -f tests/grader_redteam.py ]; then
  log "no grader red team here (a student copy leaves it out): its GPU idea tests not run"
elif [ -z "${PLAB_SKIP_REDTEAM:-}" ]; then
  log "the grader's GPU idea tests (red team gpu-ideas: each cheat and slip scores nothing, the honest 04, 05, 06-gpu full marks)"
  # Without bubblewrap, as root: the grader's unprivileged-user sandbox, the kit's answers made private.
  grade_args=""
  # The gradings' scratch where the sandbox's user can reach it (not inside a private checkout).
  scratch=$(mktemp -d /tmp/plab-gpu-redteam.XXXXXX)
  chmod 755 "$scratch"  # mktemp makes it 0700: the sandbox's uid must pass through it
  if ! command -v bwrap >/dev/null && [ "$(id -u)" = 0 ]; then grade_args="--make-private"; fi
  PYTHONPATH="$PWD/kit/python" PLAB_REDTEAM_GRADE_ARGS="$grade_args" \
    python3 tests/grader_redteam.py build-gpu/bin/plab "$PWD" "$scratch" gpu-ideas \
    > "$results/redteam-gpu.log" 2>&1 || status=1
  rm -rf "$scratch"
  grep -E '^(ok|FAIL|SKIP)|passed|failed|NOT GRADED' "$results/redteam-gpu.log" | tail -28
fi

[ -n "${PLAB_SKIP_ABLATION:-}" ] && { [ "$status" = 0 ] || echo "SOME GPU TESTS FAILED"; exit "$status"; }
log "stage 05, each change turned off in turn (PLAB_CUDA_OFF), N = 1000 and 10000"
for off in none graph streams branchless graph,streams,branchless; do
  echo "-- PLAB_CUDA_OFF=$off"
  PLAB_CUDA_OFF=$off build-gpu/bin/plab bench --stage 05 --steps 500 --n 1000,10000 \
      --runs "${PLAB_BENCH_RUNS:-3}" --csv "$results/ablation-${off//,/-}.csv" | grep -v '^median s' 
done
[ "$status" = 0 ] || echo "SOME GPU TESTS FAILED: see $results/ctest-gpu.log"
exit "$status"
