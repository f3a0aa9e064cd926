#!/usr/bin/env bash
# Stage 06 on a GPU: kernel times by Nsight Compute at N = 10^4, and the slab count swept
# (PLAB_SWEEP_ALPHA) at N = 10^4 and 10^6. A tuning aid; tools/gpu-check.sh is the full check.
set -uo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-gpu -G Ninja -DCMAKE_BUILD_TYPE=Release -DPLAB_BUILD_TESTS=OFF >/dev/null
cmake --build build-gpu -j "$(nproc)" --target plab plab-run-06-solution >/dev/null 2>&1 || exit 1
bin=build-gpu/bin
$bin/plab gen --n 10000 --l 20000 --r 1 --steps 30 --mode perf --seed 1 --out /tmp/s4.in
$bin/plab gen --n 1000000 --l 200000 --r 1 --steps 10 --mode perf --seed 1 --speed 2500:5000 --out /tmp/s6.in
if command -v ncu >/dev/null; then
  ncu --metrics gpu__time_duration.sum --launch-skip 40 --launch-count 18 \
      $bin/plab-run-06-solution /tmp/s4.in --out /dev/null 2>&1 |
    grep -E "^  [a-z_]+|gpu__time_duration" | paste - - | awk '{print $1, $(NF)}' | sort | uniq -c
fi
echo "N = 60000 (the rounds on the whole GPU): GPU against the CPU, 30 steps, every digest"
$bin/plab gen --n 60000 --l 48990 --r 1 --steps 30 --mode perf --seed 3 --out /tmp/s5.in
$bin/plab-run-06-solution /tmp/s5.in --quiet --out /tmp/g.out --digest /tmp/g.dig
PLAB_DEVICE=cpu $bin/plab-run-06-solution /tmp/s5.in --quiet --out /tmp/c.out --digest /tmp/c.dig
cmp /tmp/g.out /tmp/c.out && cmp /tmp/g.dig /tmp/c.dig && echo "N = 60000: GPU and CPU identical, output and all 31 digests"
for a in 0.25 0.5 1 2; do
  echo "alpha $a:"
  PLAB_SWEEP_ALPHA=$a $bin/plab-run-06-solution /tmp/s4.in --out /dev/null 2>&1 | grep -o "N=.*ms/step"
  PLAB_SWEEP_ALPHA=$a $bin/plab-run-06-solution /tmp/s6.in --out /dev/null 2>&1 | grep -o "N=.*ms/step"
done
