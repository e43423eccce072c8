#pragma once
// Pieces shared by the dataset readers and writers (private to fleetslam_core).

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/persistence.hpp>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::core::dataset_detail {

// ---- text lists ---------------------------------------------------------------------------------

// One data line of a text list: its 1-based line number and its fields (split at commas when the line
// has one, else at blanks). Blank lines and '#' comments are not rows.
struct TextRow {
  std::size_t line = 0;
  std::vector<std::string> fields;
};

// Reads every row of a text file. Throws InputError naming the file when it is absent or unreadable;
// `purpose` says what the file is for ("RGB image list").
std::vector<TextRow> read_text_rows(const std::filesystem::path& file, const std::string& purpose);

// Finite number or InputError at file:line naming the column.
double parse_number(const std::string& text, const std::string& where, const char* column);

// One row of an image list: stamp, image file, and the list row it came from.
struct ImageRow {
  TimeNs t_ns = 0;
  std::filesystem::path image;
  std::string where;  // "list file:line"
};

enum class StampUnit { kSeconds, kNanoseconds };

// Reads "stamp image" rows (TUM rgb.txt / depth.txt: seconds; EuRoC data.csv: nanoseconds); image
// names are resolved against image_folder. Stamps must increase strictly.
std::vector<ImageRow> read_image_list(const std::filesystem::path& list_file, StampUnit unit,
                                      const std::filesystem::path& image_folder, const std::string& purpose);

// Drops rows whose image file is absent. Absent images after the last present one are a truncated
// recording: skipped with a warning. Others are an InputError unless `skip_absent` (then warned).
// Every dropped row is appended to `skipped`.
std::vector<ImageRow> drop_absent_images(std::vector<ImageRow> rows, bool skip_absent,
                                         std::vector<SkippedRow>& skipped, const Logger& logger);

// ---- poses ----------------------------------------------------------------------------------------

// Translation linear, rotation slerp, s in [0, 1].
Eigen::Isometry3d interpolate_pose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double s);

// Where t falls in a trajectory sorted by time: on pose `index` (s == 0, an exact stamp) or between poses
// index and index + 1 at fraction s in (0, 1) when both are within max_gap_ns of t; nullopt otherwise.
struct TimeBracket {
  std::size_t index = 0;
  double s = 0.0;
};
std::optional<TimeBracket> bracket_at(const Trajectory& trajectory, TimeNs t_ns, TimeNs max_gap_ns);

// The pose there: the stamp's, or interpolated (interpolate_pose).
Eigen::Isometry3d pose_at(const Trajectory& trajectory, const TimeBracket& at);

// ---- frames ---------------------------------------------------------------------------------------

// An image a frame needs: its file and the list row naming it (for messages).
struct ImageRef {
  std::filesystem::path path;
  std::string where;
  bool empty() const { return path.empty(); }
};

// One frame of a sequence before its images are decoded.
struct FrameEntry {
  TimeNs t_ns = 0;
  ImageRef image;
  ImageRef right;
  ImageRef depth;
  std::optional<Eigen::Isometry3d> T_world_cam_gt;
  std::optional<ImuStateGt> imu_state_gt;
};

enum class ImageKind { kColour, kGray };

// A sequence indexed by a reader: everything but the pixels.
struct RecordedSequence {
  SensorRig rig;
  DatasetInfo info;
  std::vector<FrameEntry> entries;  // every usable frame, before selection, in time order
  std::vector<ImuSample> imu;       // every sample of the IMU file, in time order
  // Empty, or one entry per sample of `imu`: the truth there where the ground truth knows it, nullopt elsewhere
  // (attach_groundtruth, from body poses).
  std::vector<std::optional<ImuTruth>> imu_truth;
  ImageKind image_kind = ImageKind::kColour;
};

// Ground truth for the entries: reads `file` and gives each entry the pose at its stamp, composed with
// T_body_cam (the file's body to cam0) when the file holds body poses. Then each IMU sample gets the
// truth at its stamp: the pose of the sequence rig's body (rig_T_body_cam0: the IMU, which may differ from
// the file's body; no truth at the samples without it) and the IMU's state where the file has EuRoC's
// state columns.
// Fills the info fields about ground truth. A file that gives
// no frame a pose (another sequence's, or stamps on another clock) is an InputError naming both time
// spans when the user gave it (`given`), a warning when it is the dataset's own.
void attach_groundtruth(RecordedSequence& sequence, const std::filesystem::path& file,
                        const std::optional<Eigen::Isometry3d>& T_body_cam,
                        const std::optional<Eigen::Isometry3d>& rig_T_body_cam0, const DatasetConfig& config,
                        bool given, const Logger& logger);

// Median spacing of sorted stamps in ns (0 for fewer than two).
TimeNs median_interval_ns(const std::vector<TimeNs>& stamps);

// Samples per second over the whole list (the TUM accelerometer comes in bursts, so no median).
double mean_rate_hz(const std::vector<ImuSample>& samples);

// Builds the FrameSource over an indexed sequence (applies the selection of `config`).
std::unique_ptr<FrameSource> make_recorded_source(RecordedSequence sequence, const DatasetConfig& config,
                                                  Logger logger);

// ---- calibration files (OpenCV FileStorage YAML, "%YAML:1.0") ---------------------------------------

// Read access to one FileStorage file; every failure is an InputError "file:key: why".
class SettingsFile {
 public:
  explicit SettingsFile(const std::filesystem::path& file);
  bool has(const std::string& key) const;
  double number(const std::string& key) const;
  std::string text(const std::string& key) const;
  // A sequence of numbers, optionally nested ("T_BS" then "data"); `sizes` lists the allowed lengths.
  std::vector<double> numbers(const std::string& key, std::initializer_list<std::size_t> sizes,
                              const std::string& child = "") const;
  std::string where(const std::string& key) const { return file_ + ":" + key; }
  const std::string& file() const { return file_; }

 private:
  cv::FileNode node(const std::string& key) const;
  std::string file_;
  cv::FileStorage storage_;
};

// Writes a double so that reading it back gives the same value.
std::string exact(double value);

// ---- writing --------------------------------------------------------------------------------------

// Writers lay a sequence out in a staging folder beside `root` (root + ".partial") and rename it to
// `root` once it is complete, so that a write that fails half-way never looks like a finished sequence.
// begin: refuses a `root` that exists and is not an empty folder, removes a stale staging
// folder (an earlier write that failed: empty, or marked as fleetslam's; a folder of that name without
// the mark is refused, not removed), creates the staging folder with the mark and returns it.
std::filesystem::path begin_staged_folder(const std::filesystem::path& root);
// Renames the staging folder to `root` (an empty folder there is replaced).
void commit_staged_folder(const std::filesystem::path& staging, const std::filesystem::path& root);
// Writes an image; InputError naming the file when OpenCV cannot.
void write_image(const std::filesystem::path& file, const cv::Mat& image);

Logger or_null(Logger logger);

// Writers' check: each entry of a frame's imu_truth is at one of its IMU samples' t_ns, in time order,
// at most one per sample; InputError naming the frame (`frame_name`) otherwise.
void check_imu_truth_pairs(const SensorFrame& frame, const std::string& frame_name);

// One row of two increasing stamp lists merged in time order: from `first` (else `second`), at `index`.
struct MergedRow {
  bool from_first = true;
  std::size_t index = 0;
};
// The rows of both lists in time order, one per instant: an instant in both comes from `first` (a frame's
// own ground truth before the truth at an IMU sample).
std::vector<MergedRow> merge_in_time(const std::vector<TimeNs>& first, const std::vector<TimeNs>& second);

}  // namespace fleetslam::core::dataset_detail
