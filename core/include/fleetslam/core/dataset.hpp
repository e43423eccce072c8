#pragma once
// Recorded sequences as streams of SensorFrame: readers (FrameSource) and writers (FrameSink) for the
// TUM RGB-D, EuRoC/ASL and TUM-VI layouts. Opening a sequence reads only its text lists and
// calibration; images are decoded one frame at a time in next(), so long sequences never sit in memory.
//
//   auto source = open_dataset("data/rgbd_dataset_freiburg1_rpy", std::nullopt, {}, logger);
//   while (auto frame = source->next()) agent.process(*frame);

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/sensor_rig.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::core {

enum class DatasetFormat { kTumRgbd, kEuroc, kTumVi };

// "tum_rgbd", "euroc", "tumvi".
std::string to_string(DatasetFormat format);
std::optional<DatasetFormat> dataset_format_from_string(const std::string& name);

// How a sequence is read. Selection (index range, time range, stride) applies after association.
struct DatasetConfig {
  int robot_id = 0;                           // copied into every SensorFrame
  double max_association_difference_s = 0.02;  // TUM: RGB <-> depth stamps closer than this pair up
  // A frame gets a ground-truth pose when poses exist on both sides of its stamp no further than
  // this (interpolated between them; an exact stamp match needs no neighbour).
  double max_groundtruth_gap_s = 0.02;
  std::int64_t start_index = 0;    // first frame (after association), counted from 0
  std::int64_t stop_index = -1;    // one past the last frame; -1 = to the end
  double start_offset_s = 0.0;     // skip frames earlier than first stamp + this
  double stop_offset_s = -1.0;     // drop frames later than first stamp + this; negative = to the end
  std::int64_t stride = 1;         // keep every stride-th selected frame
  bool load_images = true;         // false: frames carry stamps, IMU and poses only (fast inspection)
  bool load_imu = true;            // attach IMU (EuRoC imu0) / accelerometer (TUM) samples
  bool stereo = true;              // EuRoC/TUM-VI: read cam1 as the right image when it exists
  // A listed image that is absent, corrupt, of the wrong size or type: false = InputError naming the
  // list file and line; true = log a warning and skip the frame. Absent images listed after the last
  // present one (truncated recordings) are always skipped with a warning.
  bool skip_unreadable_frames = false;
  double depth_scale = 0.0;        // TUM: raw depth units per metre; 0 = the rig's (5000 by default)
  // Ground truth to use instead of the dataset's own (any format read_trajectory detects). It holds
  // camera poses (T_world_cam), or body poses when groundtruth_in_body_frame is set.
  std::string groundtruth_file;
  bool groundtruth_in_body_frame = false;
  // Calibration to use instead of the dataset's own files or built-in defaults (required for TUM-VI
  // exports without sensor.yaml files, and for TUM folders of unknown cameras).
  std::optional<SensorRig> rig;
  std::string rig_source;  // where `rig` came from (a file name), reported by info()

  template <class V>
  void visit(V& v) {
    v("robot_id", robot_id, Limits<int>{0, 1 << 20});
    v("max_association_difference_s", max_association_difference_s, Limits<double>{1e-6, 1.0});  // 0 pairs nothing
    v("max_groundtruth_gap_s", max_groundtruth_gap_s, Limits<double>{0.0, 10.0});
    v("start_index", start_index, Limits<std::int64_t>{0});
    v("stop_index", stop_index, Limits<std::int64_t>{-1});
    v("start_offset_s", start_offset_s, Limits<double>{0.0, 1e9});
    v("stop_offset_s", stop_offset_s, Limits<double>{-1.0, 1e9});
    v("stride", stride, Limits<std::int64_t>{1, 1 << 20});
    v("load_images", load_images);
    v("load_imu", load_imu);
    v("stereo", stereo);
    v("skip_unreadable_frames", skip_unreadable_frames);
    v("depth_scale", depth_scale, Limits<double>{0.0, 1e9});
    v("groundtruth_file", groundtruth_file);
    v("groundtruth_in_body_frame", groundtruth_in_body_frame);
  }
};

// A list row dropped while indexing a sequence, and why.
struct SkippedRow {
  std::string where;  // "file:line"
  std::string why;
};

// What a reader learnt while indexing: enough for `fleetslam dataset info` without decoding images.
struct DatasetInfo {
  DatasetFormat format = DatasetFormat::kTumRgbd;
  std::filesystem::path root;
  std::size_t listed_frames = 0;  // rows of the main image list (rgb.txt, cam0/data.csv)
  std::size_t frames = 0;         // frames after association and selection (what size() returns)
  std::vector<SkippedRow> skipped;
  TimeNs first_t_ns = 0;          // stamps of the first and last selected frames
  TimeNs last_t_ns = 0;
  std::string groundtruth_file;   // where the poses came from; empty when there are none
  std::size_t groundtruth_poses = 0;
  std::size_t frames_with_groundtruth = 0;
  std::string calibration_source;  // "cam0/sensor.yaml", "freiburg1 defaults", "user rig", ...
  std::string imu_file;           // empty when there is no IMU / accelerometer
  std::size_t imu_samples = 0;    // samples in the file
  // Samples of the file the ground truth gives the truth at (SensorFrame::imu_truth of the frames that
  // take them), before any frame selection.
  std::size_t imu_samples_with_groundtruth = 0;
  double imu_rate_hz = 0.0;       // from the median sample interval
  bool accelerometer_only = false;  // TUM: the Kinect accelerometer, gyro fields are zero

  double duration_s() const { return ns_to_seconds(last_t_ns - first_t_ns); }
  // Mean frame rate of the selected frames (0 for fewer than two).
  double rate_hz() const;
};

// A stream of frames. next() decodes one frame's images and returns nullopt at the end.
// IMU: every frame carries the samples with t in (previous frame handed out, frame], so the samples of
// frames left out by the selection or skipped as unreadable stay in the stream; the first frame carries
// those of one (median) frame period before it.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // The next frame, or nullopt when the stream is over. Throws InputError on an unreadable frame
  // unless the source skips them.
  virtual std::optional<SensorFrame> next() = 0;
  // Frames the stream holds after selection (frames skipped as unreadable during next() make the
  // stream shorter than this).
  virtual std::size_t size() const = 0;
  virtual const SensorRig& rig() const = 0;
  virtual const DatasetInfo& info() const = 0;
  // The frames next() has skipped as unreadable so far (list row and why), in stream order.
  virtual const std::vector<SkippedRow>& unreadable_frames() const = 0;
};

// A writer of frames. write() takes frames in time order; close() completes the files (lists that
// need every frame, such as ground truth). Call it: a writer destroyed without close() leaves what it
// wrote incomplete (the sequence writers: in the staging folder beside the output, with a warning).
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  FrameSink() = default;
  FrameSink(const FrameSink&) = delete;
  FrameSink& operator=(const FrameSink&) = delete;

  virtual void write(const SensorFrame& frame) = 0;
  virtual void close() = 0;
  virtual std::size_t frames_written() const = 0;
};

// Tells the layout of a folder: rgb.txt -> TUM RGB-D; mav0/ (or a mav0 folder itself) with
// mocap0/ -> TUM-VI, otherwise EuRoC. Throws InputError naming the folder when it is none of them.
DatasetFormat detect_dataset_format(const std::filesystem::path& root);

// Opens a sequence (format detected when not given). Throws InputError for missing folders or
// files, malformed lists and calibration.
std::unique_ptr<FrameSource> open_dataset(const std::filesystem::path& root,
                                          std::optional<DatasetFormat> format,
                                          const DatasetConfig& config, Logger logger);

// A writer in the given layout (EuRoC and TUM-VI: EurocWriter). The folder is created; an existing
// non-empty folder is refused. `rig` is written as the calibration of the new sequence.
std::unique_ptr<FrameSink> make_dataset_writer(const std::filesystem::path& root, DatasetFormat format,
                                               const SensorRig& rig, Logger logger);

// Writes every remaining frame of `source` to `sink` and closes it; returns the frames written.
std::size_t copy_frames(FrameSource& source, FrameSink& sink, Logger logger);

}  // namespace fleetslam::core
