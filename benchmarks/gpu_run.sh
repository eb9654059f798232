#!/usr/bin/env bash
# The GPU batch behind docs/benchmarks.md's H200 figures, in one call of a few minutes:
#   bash benchmarks/gpu_run.sh BUNDLE.npz RESULTS_DIR [BUDGET_S] [WHEELS_DIR]
# BUNDLE.npz: `python benchmarks/gpu_capacity.py export CAPTURE OUT BUNDLE.npz` of the benchmark capture.
# WHEELS_DIR: wheels of what the machine lacks (colour-science, gsplat), installed to /tmp/site.
# 1. gpu_capacity.py: a training step of the "cpu" back-end on the host's cores at the trained capacity
#    (1 048 576), then "tiled" with all tiles at once at 32 768, 1 048 576 and 2 097 152 Gaussians
#    (every slot alive), the reference scene (1 048 576), and a 1 048 576-Gaussian training stopped at
#    the budget; 2. a step at the real-size capture's working size (bench_capture_realsize.py
#    --step-cost); 3. gsplat on the reference scene, compiled in the background once the host's cores
#    are no longer timed.
set -u
bundle=$1 res=$2 budget=${3:-330} wheels=${4:-}
# sizes (override for a quick check on a CPU: CAPS=4096 TIMES=4096,8192 STEP_G=512 METHOD=tiled); TILE:
# the tile capacity (8192 in the figures of 2026-11-29; 4096 trains 1 M Gaussians twice as fast)
caps=${CAPS:-1048576} times=${TIMES:-32768,1048576,2097152} step_g=${STEP_G:-4096,262144} tile=${TILE:-8192}
source "$(dirname "$0")/_gpu_env.sh"
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.9
(for _ in $(seq 240); do grep -q '"backend": "tiled"' "$res/capacity.json" 2>/dev/null && break; sleep 1; done
 MAX_JOBS=10 TORCH_CUDA_ARCH_LIST=9.0 timeout 420 python3 -c "from gsplat.cuda._backend import _C; print(_C)") \
  > "$res/gsplat_build.log" 2>&1 &
build=$!
python3 benchmarks/gpu_capacity.py run "$bundle" "$res/capacity.json" --budget "$budget" \
  --capacities "$caps" --time-capacities "$times" --baseline cpu --tile-capacity "$tile" --method "${METHOD:-auto}" \
  --train-anyway --reference /tmp/scene.npz 2>&1 | grep --line-buffered -v "^WARNING" > "$res/capacity.log"
timeout 90 python3 benchmarks/bench_capture_realsize.py --work /tmp/rs --step-cost --step-sizes 576x432 \
  --step-gaussians "$step_g" > "$res/realsize_step.log" 2>&1
cp /tmp/rs/results_step_cost.json "$res/" 2>/dev/null
wait $build
python3 benchmarks/gsplat_reference.py /tmp/scene.npz "$res/gsplat.json" > /dev/null 2>&1
tail -c 3000 "$res/capacity.log"; tail -5 "$res/realsize_step.log"; tail -c 600 "$res/gsplat.json"
