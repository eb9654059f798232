#!/usr/bin/env bash
# Two capacities trained to the full schedule in one short GPU call:
#   bash benchmarks/gpu_train_pair.sh BUNDLE.npz RESULTS_DIR [TRAIN_BUDGET_S] [WHEELS_DIR]
# BUNDLE.npz: `python benchmarks/gpu_capacity.py export CAPTURE OUT BUNDLE.npz` of the benchmark capture.
# 1. A training step at each capacity, alone on the device (gpu_capacity.py's timing phase; no training).
# 2. The pipeline's 3000-step schedule at every capacity, the trainings side by side on the one device
#    (each process allocates on demand), each stopped at TRAIN_BUDGET_S and scored as it stood. Sharing
#    the device changes their wall times, not what they learn: the step times to quote are phase 1's.
set -u
bundle=$1 res=$2 budget=${3:-430} wheels=${4:-}
# sizes (override for a quick check on a CPU: CAPS=2048,4096 TILE=512 METHOD=tiled STEPS=40)
caps=${CAPS:-1048576,2097152} tile=${TILE:-4096} steps=${STEPS:-3000}
source "$(dirname "$0")/_gpu_env.sh"
export XLA_PYTHON_CLIENT_PREALLOCATE=false
largest=${caps##*,}
python3 benchmarks/gpu_capacity.py run "$bundle" "$res/timing.json" --budget 150 --capacities "$largest" --time-only \
  --time-capacities "$caps" --baseline none --tile-capacity "$tile" --method "${METHOD:-auto}" --steps "$steps" \
  2>&1 | grep --line-buffered -v "^WARNING" > "$res/timing.log"
pids=()
for c in ${caps//,/ }; do
  python3 benchmarks/gpu_capacity.py run "$bundle" "$res/train_$c.json" --budget "$budget" --capacities "$c" \
    --time-capacities "$c" --baseline none --tile-capacity "$tile" --method "${METHOD:-auto}" --steps "$steps" \
    --train-anyway 2>&1 | grep --line-buffered -v "^WARNING" > "$res/train_$c.log" &
  pids+=($!)
done
wait "${pids[@]}"
tail -n 3 "$res/timing.log"
for c in ${caps//,/ }; do tail -c 1500 "$res/train_$c.log"; done
