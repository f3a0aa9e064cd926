#!/usr/bin/env bash
# Stage 06's engine on a device against its own CPU path, in every mode of its small scenes'
# search and finish (PLAB_ENGINE_BANDED on, narrow, cramped; PLAB_ENGINE_KERNELS=separate;
# PLAB_ENGINE_BANDED=off with each PLAB_ENGINE_SEARCH shape; other slab counts;
# PLAB_ENGINE_PDL=off, the bands launched after start_step without programmatic dependence), on
# scenes chosen to reach each path (the report's scene; crowded scenes whose pairs overflow the
# slots and the bands' shared memory; speeds from 10 to 20000; r = 2; sizes on both sides of the
# paths' limits).
# Every run must print the CPU's text byte for byte. Then compute-sanitizer (when there is one)
# on the report's scene: memcheck, racecheck and synccheck.
#
#   tools/engine-modes.sh [BIN_DIR] [DEVICE]     (default build-gpu/bin gpu)
#   tools/engine-modes.sh build/bin cpu          (the script's own plumbing, without a GPU)
#
# Exits 1 when a run differs or fails, or a sanitizer finds something.
set -uo pipefail
bin=${1:-build-gpu/bin}
device=${2:-gpu}
engine="$bin/plab-run-06-engine"
[ -x "$engine" ] && [ -x "$bin/plab" ] || { echo "engine-modes: no $engine or $bin/plab (build them first)"; exit 2; }
work=$(mktemp -d /tmp/plab-engine-modes.XXXXXX)
trap 'rm -rf "$work"' EXIT
status=0

gen() {  # gen NAME ARGS...: a scene
  "$bin/plab" gen "${@:2}" --out "$work/$1.in" || { echo "engine-modes: plab gen $* failed"; exit 2; }
}
gen report --n 10000 --l 20000 --r 1 --steps 500 --mode perf
gen crowded --n 5000 --l 500 --r 1 --steps 20 --mode print
gen crowded2k --n 2000 --l 300 --r 1 --steps 30 --mode print
gen wide --n 8000 --l 20000 --r 1 --steps 30 --mode perf --speed 10:20000
gen r2 --n 20000 --l 3000 --r 2 --steps 20 --mode print
gen mid --n 12000 --l 6000 --r 1 --steps 60 --mode perf
gen n40k --n 40000 --l 40000 --r 1 --steps 40 --mode perf

# Each mode: environment assignments, then options of the run (":" separates them).
modes=("PLAB_ENGINE_BANDED=on:" "PLAB_ENGINE_BANDED=narrow:" "PLAB_ENGINE_BANDED=cramped:"
       "PLAB_ENGINE_KERNELS=separate:" "PLAB_ENGINE_BANDED=off PLAB_ENGINE_SEARCH=batched:"
       "PLAB_ENGINE_BANDED=off PLAB_ENGINE_SEARCH=lean:" "PLAB_ENGINE_BANDED=off PLAB_ENGINE_SEARCH=balanced:"
       ":--sweep-alpha 0.7" ":--sweep-alpha 1.2" "PLAB_ENGINE_PDL=off:")
for scene in report crowded crowded2k wide r2 mid n40k; do
  "$engine" --device cpu --quiet --out "$work/$scene.cpu" "$work/$scene.in" || { echo "$scene: the CPU run failed"; status=1; continue; }
  line="$scene:"
  for mode in "${modes[@]}"; do
    name=$(echo "${mode/:/ }" | xargs)  # (the mode as one would type it)
    # shellcheck disable=SC2086  # the mode's words are meant to split
    if ! env ${mode%%:*} "$engine" --device "$device" ${mode#*:} --quiet --out "$work/$scene.out" \
        "$work/$scene.in" 2> "$work/$scene.err"; then
      line="$line FAILED($name: $(tail -1 "$work/$scene.err"))"
      status=1
    elif cmp -s "$work/$scene.cpu" "$work/$scene.out"; then
      line="$line same"
    else
      line="$line DIFFERS($name)"
      status=1
    fi
  done
  echo "$line  (${#modes[@]} modes)"
done

if [ "$device" = gpu ] && command -v compute-sanitizer >/dev/null; then
  for tool in memcheck racecheck synccheck; do
    if compute-sanitizer --tool "$tool" --error-exitcode 9 "$engine" --device gpu --quiet --out /dev/null \
        --steps 5 "$work/report.in" > "$work/$tool.log" 2>&1; then
      echo "compute-sanitizer $tool, the report's scene: clean"
    else
      echo "compute-sanitizer $tool, the report's scene: FOUND SOMETHING"; tail -8 "$work/$tool.log"; status=1
    fi
  done
fi
[ "$status" = 0 ] && echo "engine-modes: every mode prints the CPU's text" || echo "engine-modes: SOME RUNS DIFFER OR FAILED"
exit "$status"
