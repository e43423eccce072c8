#!/usr/bin/env bash
# The main job: the two-robot office scenario with the whole system in lockstep (world, one agent per
# robot, central unit merging their maps and planning the robots' paths; judged against ground truth
# and the scenario's pass criteria, report.html), then the real data: the dataset
# readers on TUM RGB-D and EuRoC, one agent over the real TUM excerpt (RGB-D) and one over the EuRoC
# excerpt (stereo) (trajectory, keyframes, dense map, timings, ATE), the paper's split experiment (its
# halves as two robots merged by the central unit), real reference trajectories evaluated, and a short
# synthetic sequence generated, all under out/.
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
rm -rf "$out/replay_tum_fr1_rpy" "$out/replay_euroc_v101" "$out/office_tum" "$out/run_office" "$out/split_tum_fr1_rpy"
# A run that fails its pass criteria exits 1: the rest still runs, and run.sh reports it at the end.
office_status=0
"$cli" run scenes/office/office_2robots.yaml --prior-error 0.06 -0.08 0 5 --out "$out/run_office" || office_status=$?
if [[ $office_status -gt 1 ]]; then exit "$office_status"; fi
"$cli" replay "$data/tum/rgbd_dataset_freiburg1_rpy_200" --calibration "$data/calib/TUM1.yaml" --out "$out/replay_tum_fr1_rpy"
"$cli" eval --gt "$data/tum/rgbd_dataset_freiburg1_rpy_200/groundtruth.txt" \
  --est "$out/replay_tum_fr1_rpy/trajectory.txt" --out "$out/replay_tum_fr1_rpy/eval"
"$cli" replay "$data/euroc/V1_01_easy_micro" --format euroc --sensor stereo \
  --groundtruth "$data/euroc/V1_01_easy_micro/groundtruth_leftcam_tum.txt" --out "$out/replay_euroc_v101"
"$cli" replay "$data/tum/rgbd_dataset_freiburg1_rpy_200" --calibration "$data/calib/TUM1.yaml" --split 2 \
  --out "$out/split_tum_fr1_rpy"
"$cli" generate scenes/office/office_2robots.yaml --format tum --duration 5 --out "$out/office_tum"
"$cli" eval --gt "$data/trajectories/fr2_desk_groundtruth.txt" --est "$data/trajectories/fr2_desk_ORB.txt" \
  --align se3 --out "$out/eval_fr2_desk_orb"
"$cli" eval --gt "$data/trajectories/freiburg1_xyz-groundtruth.txt" --est "$data/trajectories/freiburg1_xyz-ORB_kf_mono.txt" \
  --align sim3 --out "$out/eval_fr1_xyz_orb_mono"
echo "run.sh: outputs in $out/ (the office run's report: $out/run_office/report.html)"
if [[ $office_status -ne 0 ]]; then
  echo "run.sh: the office run failed its pass criteria (see $out/run_office/report.html)" >&2
  exit 1
fi
