// Trajectory files: TUM, EuRoC csv and KITTI 3x4 (see trajectory.hpp for the formats).

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string_view>
#include <system_error>

#include <Eigen/SVD>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::core {
namespace {

namespace fs = std::filesystem;

// One physical line of a file; `complete` is false for a last line without its newline.
struct Line {
  std::size_t number = 0;
  std::string text;
  bool complete = true;
};

bool is_blank_char(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank_char(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank_char(s.back())) s.remove_suffix(1);
  return s;
}

// A file's whole text, read once: the format detection, the unit check and the parser all read it, and a
// named pipe (eval --est <(...)) can be read only once.
struct FileText {
  std::string file;
  std::string text;
};

FileText read_file_text(const fs::path& path) {
  FileText out{path.string(), {}};
  if (fs::is_directory(path)) throw InputError(out.file, "is a folder, not a trajectory file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(out.file, "cannot open the file");
  std::array<char, 1 << 16> buffer{};
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
    out.text.append(buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw InputError(out.file, "read error");
  return out;
}

// Reads lines one by one, skipping blank lines and '#' comments (kept as the header).
class DataLineReader {
 public:
  explicit DataLineReader(const FileText& file) : file_(file.file), in_(file.text) {}

  bool next(Line& line) {
    std::string text;
    while (std::getline(in_, text)) {
      ++number_;
      const std::string_view body = trim(text);
      if (body.empty()) continue;
      if (body.front() == '#') {
        header_ += std::string(body) + "\n";
        continue;
      }
      line.number = number_;
      line.complete = !in_.eof();
      line.text = std::move(text);
      return true;
    }
    if (in_.bad()) throw InputError(at_line(file_, number_ + 1), "read error");
    return false;
  }

  const std::string& file() const { return file_; }
  const std::string& header() const { return header_; }
  std::size_t lines_read() const { return number_; }

 private:
  std::string file_;
  std::istringstream in_;
  std::size_t number_ = 0;
  std::string header_;
};

// Splits on runs of spaces/tabs or on one comma with optional spaces around it. An empty field
// (",,", a leading or trailing comma) is an error: a column went missing.
std::vector<std::string_view> split_fields(std::string_view text, const std::string& where) {
  std::vector<std::string_view> fields;
  std::size_t i = 0;
  auto skip_blanks = [&] {
    while (i < text.size() && is_blank_char(text[i])) ++i;
  };
  skip_blanks();
  bool expect_field = false;  // after a comma a field must follow
  while (i < text.size()) {
    const std::size_t start = i;
    while (i < text.size() && !is_blank_char(text[i]) && text[i] != ',') ++i;
    if (i == start) throw InputError(where, "empty field (two separators in a row or a leading comma)");
    fields.push_back(text.substr(start, i - start));
    skip_blanks();
    expect_field = i < text.size() && text[i] == ',';
    if (expect_field) {
      ++i;
      skip_blanks();
    }
  }
  if (expect_field) throw InputError(where, "empty field after a trailing comma");
  return fields;
}

double parse_value(std::string_view field, const std::string& where) {
  if (!field.empty() && field.front() == '+') field.remove_prefix(1);  // from_chars rejects '+'
  double value = 0.0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || end != field.data() + field.size()) {
    throw InputError(where, "not a number: '" + std::string(field) + "'");
  }
  if (!std::isfinite(value)) throw InputError(where, "value is not finite: '" + std::string(field) + "'");
  return value;
}

// Digits before the decimal point (sign excluded); tells nanosecond stamps from seconds.
std::size_t integer_digits(std::string_view field) {
  if (!field.empty() && (field.front() == '-' || field.front() == '+')) field.remove_prefix(1);
  std::size_t n = 0;
  while (n < field.size() && std::isdigit(static_cast<unsigned char>(field[n]))) ++n;
  return n;
}

// True for "123" or "123.000": an unsigned integer, possibly written with a fraction of zeros.
bool is_integer_text(std::string_view field) {
  const std::size_t n = integer_digits(field);
  if (n == 0 || !std::isdigit(static_cast<unsigned char>(field.front()))) return false;
  if (n == field.size()) return true;
  const std::string_view fraction = field.substr(n + 1);
  return field[n] == '.' && std::all_of(fraction.begin(), fraction.end(), [](char c) { return c == '0'; });
}

// A seconds value of 16+ integer digits is not seconds (3e8 years): such stamps are nanoseconds.
constexpr std::size_t kNanosecondDigits = 16;

// A file whose stamps are all whole numbers this far apart (median step) counts them in nanoseconds: as
// seconds, a pose every 1000 s is no trajectory, while nanosecond stamps that start near 0 (a simulation's
// clock) are short, e.g. ORB-SLAM3's EuRoC output "50000000.000000 tx ty tz qx qy qz qw".
constexpr double kNanosecondStepSeconds = 1000.0;

TimeNs parse_tum_stamp(std::string_view field, const std::string& where, bool nanoseconds) {
  const auto t_ns = nanoseconds || integer_digits(field) >= kNanosecondDigits ? parse_nanoseconds(field)
                                                                              : parse_seconds(field);
  if (!t_ns) throw InputError(where, "bad timestamp '" + std::string(field) + "'");
  return *t_ns;
}

TimeNs parse_euroc_stamp(std::string_view field, const std::string& where) {
  // Integer nanoseconds; a fraction other than zeros ("1403715274312143104.0000000000" occurs) means the
  // stamps are seconds, as in a TUM file read as EuRoC.
  const auto dot = field.find('.');
  if (dot != std::string_view::npos && field.find_first_not_of('0', dot + 1) != std::string_view::npos) {
    throw InputError(where, "timestamp '" + std::string(field) +
                                "' has a fraction: EuRoC stamps are integer nanoseconds (is this a TUM file? "
                                "stamps in seconds, quaternion last)");
  }
  const auto t_ns = parse_nanoseconds(field);
  if (!t_ns) throw InputError(where, "bad nanosecond timestamp '" + std::string(field) + "'");
  return *t_ns;
}

Eigen::Isometry3d pose_from_quaternion(const Eigen::Vector3d& t, Eigen::Quaterniond q, const std::string& where) {
  const double norm = q.norm();
  // Files round quaternions to a few digits, so only a vanishing norm is refused.
  if (!(norm > 1e-6)) throw InputError(where, "zero-norm quaternion");
  q.coeffs() /= norm;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = t;
  return T;
}

Eigen::Isometry3d pose_from_kitti(const std::array<double, 12>& v, const std::string& where) {
  Eigen::Matrix3d R;
  R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthogonality < 1e-3) || R.determinant() <= 0.0) {
    throw InputError(where, "the 3x3 part is not a rotation matrix");
  }
  // Printed matrices are rotations only to their last digit: project onto SO(3).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
  return T;
}

std::string column_count_message(const Line& line, std::size_t found, const std::string& expected) {
  const std::string what = line.complete ? "wrong number of columns" : "truncated line";
  return what + " (expected " + expected + ", found " + std::to_string(found) + ")";
}

StampedPose parse_tum_line(const Line& line, const std::vector<std::string_view>& f, const std::string& where,
                           bool nanoseconds) {
  if (f.size() != 8) throw InputError(where, column_count_message(line, f.size(), "8: t tx ty tz qx qy qz qw"));
  std::array<double, 7> v{};
  for (std::size_t i = 0; i < 7; ++i) v[i] = parse_value(f[i + 1], where);
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);  // Eigen's constructor takes w first
  return {parse_tum_stamp(f[0], where, nanoseconds), pose_from_quaternion(Eigen::Vector3d(v[0], v[1], v[2]), q, where)};
}

StampedPose parse_euroc_line(const Line& line, const std::vector<std::string_view>& f, const std::string& where,
                             std::vector<double>& after_pose) {
  if (f.size() < 8) {
    throw InputError(where, column_count_message(line, f.size(), "at least 8: t_ns px py pz qw qx qy qz"));
  }
  std::array<double, 7> v{};
  for (std::size_t i = 0; i < 7; ++i) v[i] = parse_value(f[i + 1], where);
  after_pose.clear();
  for (std::size_t i = 8; i < f.size(); ++i) after_pose.push_back(parse_value(f[i], where));  // must be numbers
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  return {parse_euroc_stamp(f[0], where), pose_from_quaternion(Eigen::Vector3d(v[0], v[1], v[2]), q, where)};
}

StampedPose parse_kitti_line(const Line& line, const std::vector<std::string_view>& f, const std::string& where,
                             TimeNs index) {
  if (f.size() != 12) throw InputError(where, column_count_message(line, f.size(), "12: a 3x4 matrix"));
  std::array<double, 12> v{};
  for (std::size_t i = 0; i < 12; ++i) v[i] = parse_value(f[i], where);
  return {index, pose_from_kitti(v, where)};
}

// Adds a pose, enforcing increasing stamps; equal stamps follow the policy.
void append_pose(TrajectoryFile& out, StampedPose pose, const std::string& where, std::size_t line_number,
                 DuplicateStamps policy) {
  Trajectory& poses = out.trajectory;
  if (!poses.empty() && pose.t_ns <= poses.back().t_ns) {
    const std::string stamps =
        format_seconds(pose.t_ns) + " s after " + format_seconds(poses.back().t_ns) + " s";
    if (pose.t_ns < poses.back().t_ns) throw InputError(where, "timestamps decrease (" + stamps + ")");
    if (policy == DuplicateStamps::kError) throw InputError(where, "repeated timestamp (" + stamps + ")");
    if (out.duplicates_dropped++ == 0) out.first_duplicate_line = line_number;
    if (policy == DuplicateStamps::kKeepLast) poses.back() = pose;
    return;
  }
  poses.push_back(pose);
}

bool header_names_nanoseconds(const std::string& header) {
  return header.find("[ns]") != std::string::npos || header.find("_ns") != std::string::npos;
}

// Whether the header names the quaternion w first ("q_RS_w, q_RS_x", "qw qx"), x first ("qx ... qw"), or
// neither: columns "qw"/"q_w"/"q_<frames>_w" and the same for x.
std::optional<bool> header_quaternion_w_first(const std::string& header) {
  std::optional<std::size_t> w, x;
  std::size_t index = 0;
  std::string token;
  const auto take = [&] {
    if (token.empty()) return;
    std::string t;
    for (const char c : token) t += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const bool quaternion = t.size() >= 2 && t[0] == 'q' && (t.size() == 2 || t[1] == '_');
    if (quaternion && t.back() == 'w' && !w) w = index;
    if (quaternion && t.back() == 'x' && !x) x = index;
    ++index;
    token.clear();
  };
  for (const char c : header) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == ',' || c == '#' || c == '[' || c == ']') {
      take();
    } else {
      token += c;
    }
  }
  take();
  if (!w || !x) return std::nullopt;
  return *w < *x;
}

}  // namespace

std::string to_string(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum: return "tum";
    case TrajectoryFormat::kEuroc: return "euroc";
    case TrajectoryFormat::kKitti: return "kitti";
  }
  return "unknown";
}

std::optional<TrajectoryFormat> trajectory_format_from_string(const std::string& name) {
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); });
  if (lower == "tum") return TrajectoryFormat::kTum;
  if (lower == "euroc") return TrajectoryFormat::kEuroc;
  if (lower == "kitti") return TrajectoryFormat::kKitti;
  return std::nullopt;
}

namespace {

TrajectoryFormat detect_format(const FileText& file) {
  DataLineReader reader(file);
  Line line;
  if (!reader.next(line)) throw InputError(reader.file(), "no poses in the file (empty or only comments)");
  const std::string where = at_line(reader.file(), line.number);
  const auto fields = split_fields(line.text, where);
  const bool comma_separated = line.text.find(',') != std::string::npos;
  const bool ns_header = header_names_nanoseconds(reader.header());
  // "1403715274312143104.0000000000" is a ns stamp, "1.000000" a stamp in seconds.
  const bool long_integer_stamp =
      !fields.empty() && is_integer_text(fields[0]) && integer_digits(fields[0]) >= kNanosecondDigits;
  const bool integer_stamp = long_integer_stamp || (!fields.empty() && is_integer_text(fields[0]) &&
                                                    fields[0].find('.') == std::string_view::npos);
  const std::size_t n = fields.size();
  // KITTI rows start with a rotation entry, which may print as "1": only a real ns stamp means EuRoC.
  if (n == 12) return long_integer_stamp || (integer_stamp && ns_header) ? TrajectoryFormat::kEuroc
                                                                         : TrajectoryFormat::kKitti;
  // Space-separated 8 columns with ns stamps is ORB-SLAM3's TUM-ordered output: TUM reads those stamps.
  // A header that names the quaternion's columns decides their order ("# timestamp [ns] tx ty tz qx qy qz
  // qw" is TUM's order whatever its stamps).
  if (n == 8) {
    const std::optional<bool> w_first = header_quaternion_w_first(reader.header());
    if (w_first && *w_first && !integer_stamp) {
      throw InputError(where, "the header puts the quaternion's w first (EuRoC's order) but the stamps are not "
                              "integer nanoseconds: neither TUM nor EuRoC");
    }
    if (w_first) return *w_first ? TrajectoryFormat::kEuroc : TrajectoryFormat::kTum;
    return integer_stamp && (comma_separated || ns_header) ? TrajectoryFormat::kEuroc : TrajectoryFormat::kTum;
  }
  if (n > 8 && integer_stamp) return TrajectoryFormat::kEuroc;
  throw InputError(where, "cannot tell the trajectory format from " + std::to_string(fields.size()) +
                              " columns (TUM has 8, EuRoC 8 or more with integer ns stamps, KITTI 12)");
}

// Whether a TUM file's stamps are nanoseconds as a whole: all whole numbers (a fraction of zeros allowed)
// with a median step of at least kNanosecondStepSeconds. Lines it cannot read are left to the parser.
bool tum_stamps_in_nanoseconds(const FileText& file) {
  DataLineReader reader(file);
  Line line;
  std::vector<double> stamps;
  while (reader.next(line)) {
    const auto fields = split_fields(line.text, at_line(reader.file(), line.number));
    if (fields.empty()) continue;
    const std::string_view field = fields[0];
    if (!is_integer_text(field)) return false;
    double value = 0.0;
    const std::size_t digits = integer_digits(field);
    const auto [ptr, ec] = std::from_chars(field.data(), field.data() + digits, value);
    if (ec != std::errc() || ptr != field.data() + digits) return false;
    stamps.push_back(value);
  }
  std::vector<double> steps;
  for (std::size_t i = 1; i < stamps.size(); ++i) {
    if (stamps[i] > stamps[i - 1]) steps.push_back(stamps[i] - stamps[i - 1]);
  }
  if (steps.empty()) return false;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2] >= kNanosecondStepSeconds;
}

}  // namespace

TrajectoryFormat detect_trajectory_format(const fs::path& path) { return detect_format(read_file_text(path)); }

TrajectoryFile read_trajectory_file(const fs::path& path, const TrajectoryReadOptions& options) {
  TrajectoryFile out;
  const FileText file = read_file_text(path);
  out.format = options.format ? *options.format : detect_format(file);
  const bool tum_nanoseconds = out.format == TrajectoryFormat::kTum && tum_stamps_in_nanoseconds(file);
  DataLineReader reader(file);
  Line line;
  TimeNs kitti_index = 0;
  const bool keep_after = options.keep_columns_after_pose && out.format == TrajectoryFormat::kEuroc;
  std::vector<double> after_pose;
  std::optional<std::size_t> columns_after;  // of the first line, when kept: every line must have as many
  while (reader.next(line)) {
    const std::string where = at_line(reader.file(), line.number);
    const auto fields = split_fields(line.text, where);
    StampedPose pose;
    switch (out.format) {
      case TrajectoryFormat::kTum: pose = parse_tum_line(line, fields, where, tum_nanoseconds); break;
      case TrajectoryFormat::kEuroc: pose = parse_euroc_line(line, fields, where, after_pose); break;
      case TrajectoryFormat::kKitti: pose = parse_kitti_line(line, fields, where, kitti_index++); break;
    }
    const std::size_t before = out.trajectory.size();
    const std::size_t duplicates = out.duplicates_dropped;
    append_pose(out, pose, where, line.number, options.duplicate_stamps);
    if (!keep_after) continue;
    // A line with fewer (or more) columns than the others would silently drop a state column for all.
    if (!columns_after) columns_after = after_pose.size();
    if (after_pose.size() != *columns_after) {
      throw InputError(where, std::to_string(8 + after_pose.size()) + " columns where the first line has " +
                                  std::to_string(8 + *columns_after) +
                                  " (every line of a EuRoC ground truth has the same columns)");
    }
    if (out.trajectory.size() > before) {
      out.columns_after_pose.push_back(after_pose);
    } else if (out.duplicates_dropped > duplicates && options.duplicate_stamps == DuplicateStamps::kKeepLast) {
      out.columns_after_pose.back() = after_pose;
    }
  }
  if (out.trajectory.empty()) {
    throw InputError(reader.file(), "no poses in the file (empty or only comments)");
  }
  return out;
}

Trajectory read_trajectory(const fs::path& path, std::optional<TrajectoryFormat> format) {
  TrajectoryReadOptions options;
  options.format = format;
  return read_trajectory_file(path, options).trajectory;
}

namespace {

// Shortest text that reads back to the same double.
void put_number(std::string& out, double value) {
  std::array<char, 32> buffer{};
  const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  FLEETSLAM_CHECK(ec == std::errc(), "to_chars failed");
  out.append(buffer.data(), end);
}

}  // namespace

std::string trajectory_file_header(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum: return "# timestamp tx ty tz qx qy qz qw\n";
    case TrajectoryFormat::kEuroc:
      return "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\n";
    case TrajectoryFormat::kKitti: break;
  }
  return "";
}

std::string format_trajectory_line(const StampedPose& pose, TrajectoryFormat format) {
  const Eigen::Vector3d t = pose.T_world_body.translation();
  const Eigen::Matrix3d R = pose.T_world_body.linear();
  const Eigen::Quaterniond q(R);
  std::vector<double> values;
  std::string out;
  char separator = ' ';
  switch (format) {
    case TrajectoryFormat::kTum:
      out = format_seconds(pose.t_ns, 9);
      values = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
      break;
    case TrajectoryFormat::kEuroc:
      out = std::to_string(pose.t_ns);
      separator = ',';
      values = {t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z()};
      break;
    case TrajectoryFormat::kKitti:
      for (int r = 0; r < 3; ++r) values.insert(values.end(), {R(r, 0), R(r, 1), R(r, 2), t(r)});
      break;
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!out.empty() || i > 0) out += separator;
    put_number(out, values[i]);
  }
  out += '\n';
  return out;
}

void write_trajectory(const fs::path& path, const Trajectory& trajectory, TrajectoryFormat format) {
  const std::string file = path.string();
  std::error_code ec;
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), ec);
  if (ec) throw InputError(file, "cannot create the folder: " + ec.message());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(file, "cannot open the file for writing");
  out << trajectory_file_header(format);
  for (const StampedPose& pose : trajectory) out << format_trajectory_line(pose, format);
  out.flush();
  if (!out) throw InputError(file, "write failed");
}

}  // namespace fleetslam::core
