# Sourced by the GPU batches (gpu_run.sh, gpu_train_pair.sh) with $res and $wheels set: installs the
# carried wheels to /tmp/site, sets PYTHONPATH to them and this repository, records the device, and
# stops the batch at once if the project does not import (seconds, not minutes, of device time).
mkdir -p "$res"
if [ -n "$wheels" ]; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site "$wheels"/*.whl \
    && export PYTHONPATH=/tmp/site:$PWD || exit 1
else
  export PYTHONPATH=$PWD
fi
export PYTHONUNBUFFERED=1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv > "$res/gpu.txt" 2>&1
python3 -c "import splat.training, splat.capture" || exit 1
