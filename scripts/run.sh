#!/usr/bin/env bash
# The main job. Until the closed-loop scenario exists this is the furthest pipeline that works:
# stream the real TUM RGB-D and EuRoC sequences through the dataset readers, and evaluate real SLAM
# trajectories against ground truth (ATE/RPE, metrics.json and an SVG plot) under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh release
cli=build/release/tools/fleetslam
data="${FLEETSLAM_DATA_DIR:-../shared/data}"
out="${1:-out}"
mkdir -p "$out"
if [[ ! -d "$data" ]]; then
  echo "run.sh: real data folder '$data' not found (set FLEETSLAM_DATA_DIR)" >&2
  exit 1
fi
"$cli" dataset info "$data/tum/rgbd_dataset_freiburg1_rpy_200"
"$cli" dataset info "$data/euroc/V1_01_easy_micro" \
  --groundtruth "$data/euroc/V1_01_easy_micro/groundtruth_leftcam_tum.txt"
"$cli" eval --gt "$data/trajectories/fr2_desk_groundtruth.txt" --est "$data/trajectories/fr2_desk_ORB.txt" \
  --align se3 --out "$out/eval_fr2_desk_orb"
"$cli" eval --gt "$data/trajectories/freiburg1_xyz-groundtruth.txt" --est "$data/trajectories/freiburg1_xyz-ORB_kf_mono.txt" \
  --align sim3 --out "$out/eval_fr1_xyz_orb_mono"
echo "run.sh: outputs in $out/"
