#include "fleetslam/core/orbslam_settings.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <utility>
#include <string>
#include <system_error>

#include <opencv2/core.hpp>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"

namespace fleetslam::core {
namespace {

// Rotations of a rigid matrix may be off orthonormal by this much (files store 4x4 floats rounded by
// hand); within it they are projected onto SO(3), beyond it the matrix is rejected.
constexpr double kOrthonormalTolerance = 1e-3;
constexpr double kBottomRowTolerance = 1e-6;
// A rotation computed in double arithmetic is off orthonormal by a few ulps; such a matrix is kept as
// written, so that a file written by write_orbslam_settings reads back bit-exactly (projecting it onto
// SO(3) would move its entries by an ulp or so).
constexpr double kRoundingOrthonormality = 2e-15;

std::string format_number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", value);
  return buffer;
}

std::string describe(const cv::FileNode& node) {
  if (node.isString()) return "the string '" + static_cast<std::string>(node) + "'";
  if (node.isSeq()) return "a list";
  if (node.isMap()) return "a map";
  if (node.isInt() || node.isReal()) return "the number " + format_number(static_cast<double>(node));
  return "nothing";
}

// The first non-blank line must be the FileStorage header; OpenCV's own message for a plain YAML file
// ("Input file is invalid") does not say what is wrong.
bool starts_with_yaml_header(std::istream& in) {
  std::string line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    return line.rfind("%YAML", 0) == 0;
  }
  return false;
}

// A settings file open for reading. Every error names "file:key".
class SettingsFile {
 public:
  explicit SettingsFile(const std::filesystem::path& file) : name_(file.string()) {
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) throw InputError(name_, "settings file not found");
    if (std::filesystem::is_directory(file, ec)) throw InputError(name_, "is a directory, not a settings file");
    std::ifstream in(file);
    if (!in) throw InputError(name_, "cannot open settings file");
    if (!starts_with_yaml_header(in)) {
      throw InputError(name_, "not an OpenCV FileStorage YAML file: the first line must be %YAML:1.0");
    }
    try {
      storage_.open(name_, cv::FileStorage::READ);
    } catch (const cv::Exception& e) {
      throw parse_error(e);
    }
    if (!storage_.isOpened()) throw InputError(name_, "cannot open settings file");
  }

  [[noreturn]] void fail(const std::string& key, const std::string& why) const {
    throw InputError(name_ + ":" + key, why);
  }

  bool has(const std::string& key) const { return !node(key).isNone(); }
  bool has_any(std::initializer_list<const char*> keys) const {
    for (const char* key : keys) {
      if (has(key)) return true;
    }
    return false;
  }

  std::optional<double> real(const std::string& key) const {
    const cv::FileNode n = node(key);
    if (n.isNone()) return std::nullopt;
    if (!n.isReal() && !n.isInt()) fail(key, "expected a number, got " + describe(n));
    const double value = static_cast<double>(n);
    if (!std::isfinite(value)) fail(key, "expected a finite number, got " + format_number(value));
    return value;
  }

  std::optional<int> integer(const std::string& key) const {
    const cv::FileNode n = node(key);
    if (n.isNone()) return std::nullopt;
    if (n.isInt()) return static_cast<int>(n);
    // 1000.0 is accepted as 1000; 1000.5 is not.
    const double value = n.isReal() ? static_cast<double>(n) : std::nan("");
    if (!(std::isfinite(value) && value == std::floor(value) && std::abs(value) < 2e9)) {
      fail(key, "expected an integer, got " + describe(n));
    }
    return static_cast<int>(value);
  }

  std::optional<std::string> text(const std::string& key) const {
    const cv::FileNode n = node(key);
    if (n.isNone()) return std::nullopt;
    if (n.isString()) return static_cast<std::string>(n);
    if (n.isInt() || n.isReal()) return format_number(static_cast<double>(n));
    fail(key, "expected a string, got " + describe(n));
  }

  // A 4x4 !!opencv-matrix holding a rigid transformation.
  std::optional<Eigen::Isometry3d> rigid(const std::string& key) const {
    const cv::FileNode n = node(key);
    if (n.isNone()) return std::nullopt;
    return to_rigid(key, read_matrix(key, n));
  }

  template <class T>
  T required(const std::optional<T>& value, const std::string& key) const {
    if (!value) fail(key, "required key is missing" + missing_hint(key));
    return *value;
  }

 private:
  cv::FileNode node(const std::string& key) const { return storage_[key]; }

  // OpenCV 4.x reports parse errors with the message "<file>(<line>): <why>" in Exception::func (and
  // its parser's function name in Exception::err); the line goes into "where" when it is there.
  InputError parse_error(const cv::Exception& e) const {
    const std::string prefix = name_ + "(";
    if (e.code == cv::Error::StsParseError && e.func.rfind(prefix, 0) == 0) {
      const std::size_t close = e.func.find("): ", prefix.size());
      const std::string line = e.func.substr(prefix.size(), close - prefix.size());
      if (close != std::string::npos && !line.empty() &&
          line.find_first_not_of("0123456789") == std::string::npos) {
        return InputError(name_ + ":" + line, "malformed OpenCV YAML: " + e.func.substr(close + 3));
      }
    }
    return InputError(name_, "malformed OpenCV YAML: " + e.err + " (" + e.func + ")");
  }

  cv::Mat read_matrix(const std::string& key, const cv::FileNode& n) const {
    if (!n.isMap()) fail(key, "expected a 4x4 !!opencv-matrix, got " + describe(n));
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception& e) {
      fail(key, "malformed !!opencv-matrix (rows, cols, dt and data must agree): " + e.err);
    }
    if (m.empty()) fail(key, "expected a 4x4 !!opencv-matrix, got an empty or untagged map");
    if (m.rows != 4 || m.cols != 4 || m.channels() != 1) {
      fail(key, "expected a 4x4 matrix, got " + std::to_string(m.rows) + "x" + std::to_string(m.cols) +
                    (m.channels() != 1 ? " with " + std::to_string(m.channels()) + " channels" : ""));
    }
    cv::Mat m64;
    m.convertTo(m64, CV_64F);
    read_exact_entries(n["data"], m64);
    return m64;
  }

  // FileStorage converts the entries to the dt tag's type, so a "dt: f" matrix (ORB-SLAM3 reads floats)
  // would lose the digits beyond float; the decimal text itself reads back at double precision.
  static void read_exact_entries(const cv::FileNode& data, cv::Mat& m64) {
    if (!data.isSeq() || data.size() != m64.total()) return;
    auto* entry = m64.ptr<double>();
    for (const cv::FileNode& value : data) {
      if (value.isReal() || value.isInt()) *entry = static_cast<double>(value);
      ++entry;
    }
  }

  Eigen::Isometry3d to_rigid(const std::string& key, const cv::Mat& m) const {
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) M(r, c) = m.at<double>(r, c);
    }
    if (!M.allFinite()) fail(key, "matrix has non-finite entries");
    if ((M.row(3) - Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0)).cwiseAbs().maxCoeff() > kBottomRowTolerance) {
      fail(key, "not a rigid transformation: the bottom row must be 0 0 0 1");
    }
    const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
    const double error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (error > kOrthonormalTolerance) {
      fail(key, "not a rigid transformation: the rotation part is not orthonormal (max |R^T R - I| = " +
                    format_number(error) + ", tolerance " + format_number(kOrthonormalTolerance) + ")");
    }
    if (R.determinant() < 0.0) fail(key, "not a rigid transformation: the rotation part is a reflection");
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = M.topRightCorner<3, 1>();
    if (error <= kRoundingOrthonormality) return T;
    return normalized(T);  // removes the rounding of a rotation stored with few digits
  }

  // Points at the other layout when its key is there instead ("Camera1.fx" in an old-layout file).
  std::string missing_hint(const std::string& key) const {
    const auto swapped = [&](const std::string& from, const std::string& to) -> std::string {
      if (key.rfind(from, 0) != 0) return "";
      const std::string other = to + key.substr(from.size());
      return has(other) ? other : "";
    };
    if (const std::string other = swapped("Camera.", "Camera1."); !other.empty()) {
      return " (the file has " + other + ": add File.version: \"1.0\" for the ORB-SLAM3 v1.0 layout)";
    }
    if (const std::string other = swapped("Camera1.", "Camera."); !other.empty()) {
      return " (the file has " + other + " of the old layout: remove File.version or rename the keys)";
    }
    return "";
  }

  std::string name_;
  cv::FileStorage storage_;
};

// Key names that differ between the old and the v1.0 layouts.
struct Layout {
  bool v1 = false;
  bool rectified = false;        // v1.0 Camera.type "Rectified": one camera plus Stereo.b
  bool fisheye = false;          // Camera.type "KannalaBrandt8": equidistant cameras (k1..k4)
  std::string cam0;              // "Camera." / "Camera1."
  std::string depth_map_factor;  // "DepthMapFactor" / "RGBD.DepthMapFactor"
  std::string th_depth;          // "ThDepth" / "Stereo.ThDepth"
  std::string T_body_cam0;       // "Tbc" / "IMU.T_b_c1" (either is accepted in both layouts)
};

bool read_is_v1(const SettingsFile& f) {
  const std::optional<std::string> version = f.text("File.version");
  if (!version) return false;
  if (*version == "1.0" || *version == "1") return true;
  f.fail("File.version", "unsupported version '" + *version + "': expected \"1.0\", or no File.version for the "
                         "old ORB-SLAM2 layout");
}

Layout read_layout(const SettingsFile& f) {
  Layout layout;
  layout.v1 = read_is_v1(f);
  const std::string type = f.text("Camera.type").value_or("PinHole");
  if (type != "PinHole" && type != "Rectified" && type != "KannalaBrandt8") {
    f.fail("Camera.type", "unknown camera type '" + type + "': expected PinHole, Rectified or KannalaBrandt8");
  }
  layout.rectified = type == "Rectified";
  layout.fisheye = type == "KannalaBrandt8";
  layout.cam0 = layout.v1 ? "Camera1." : "Camera.";
  layout.depth_map_factor = layout.v1 ? "RGBD.DepthMapFactor" : "DepthMapFactor";
  layout.th_depth = layout.v1 ? "Stereo.ThDepth" : "ThDepth";
  layout.T_body_cam0 = layout.v1 ? "IMU.T_b_c1" : "Tbc";
  return layout;
}

bool has_imu_keys(const SettingsFile& f) {
  return f.has_any({"IMU.T_b_c1", "Tbc", "IMU.NoiseGyro", "IMU.NoiseAcc", "IMU.GyroWalk", "IMU.AccWalk",
                    "IMU.Frequency"});
}

bool has_second_camera(const SettingsFile& f, const Layout& layout) {
  if (layout.v1) return layout.rectified || f.has_any({"Camera2.fx", "Stereo.T_c1_c2", "Stereo.b"});
  return f.has("Camera.bf");  // the old stereo layout describes a rectified pair by its bf
}

SensorMode infer_mode(const SettingsFile& f, const Layout& layout) {
  if (f.has(layout.depth_map_factor)) return SensorMode::kRgbd;
  const bool inertial = has_imu_keys(f);
  if (has_second_camera(f, layout)) return inertial ? SensorMode::kStereoInertial : SensorMode::kStereo;
  return inertial ? SensorMode::kMonoInertial : SensorMode::kMonocular;
}

bool is_stereo(SensorMode mode) { return mode == SensorMode::kStereo || mode == SensorMode::kStereoInertial; }
bool is_inertial(SensorMode mode) {
  return mode == SensorMode::kMonoInertial || mode == SensorMode::kStereoInertial;
}

double positive(const SettingsFile& f, const std::string& key, double value, const char* what = "value") {
  if (!(value > 0.0)) f.fail(key, std::string(what) + " must be positive, got " + format_number(value));
  return value;
}

double required_positive(const SettingsFile& f, const std::string& key, const char* what = "value") {
  return positive(f, key, f.required(f.real(key), key), what);
}

int required_positive_int(const SettingsFile& f, const std::string& key) {
  const int value = f.required(f.integer(key), key);
  if (value <= 0) f.fail(key, "must be a positive integer, got " + std::to_string(value));
  return value;
}

PinholeCamera read_camera(const SettingsFile& f, const std::string& prefix, int width, int height, bool fisheye) {
  const double fx = required_positive(f, prefix + "fx", "focal length");
  const double fy = required_positive(f, prefix + "fy", "focal length");
  const double cx = f.required(f.real(prefix + "cx"), prefix + "cx");
  const double cy = f.required(f.real(prefix + "cy"), prefix + "cy");
  if (fisheye) {  // ORB-SLAM3's KannalaBrandt8 reads all four coefficients
    double k[4] = {};
    for (int i = 0; i < 4; ++i) {  // in order, so that the first missing one is named
      const std::string key = prefix + "k" + std::to_string(i + 1);
      k[i] = f.required(f.real(key), key);
    }
    return PinholeCamera(width, height, fx, fy, cx, cy, Distortion::equidistant(k[0], k[1], k[2], k[3]));
  }
  Distortion d;
  d.k1 = f.real(prefix + "k1").value_or(0.0);
  d.k2 = f.real(prefix + "k2").value_or(0.0);
  d.p1 = f.real(prefix + "p1").value_or(0.0);
  d.p2 = f.real(prefix + "p2").value_or(0.0);
  d.k3 = f.real(prefix + "k3").value_or(0.0);
  return PinholeCamera(width, height, fx, fy, cx, cy, d);
}

void read_image_settings(const SettingsFile& f, OrbSlamSettings& s) {
  if (const std::optional<double> fps = f.real("Camera.fps")) s.rig.fps = positive(f, "Camera.fps", *fps, "frame rate");
  if (const std::optional<int> rgb = f.integer("Camera.RGB")) {
    if (*rgb != 0 && *rgb != 1) f.fail("Camera.RGB", "expected 0 (BGR) or 1 (RGB), got " + std::to_string(*rgb));
    s.rig.rgb_order = *rgb == 1;
  }
  if (f.has("Camera.newWidth") || f.has("Camera.newHeight")) {
    s.new_width = required_positive_int(f, "Camera.newWidth");
    s.new_height = required_positive_int(f, "Camera.newHeight");
  }
}

void read_orb_extractor(const SettingsFile& f, OrbExtractorSettings& orb) {
  const auto positive_int = [&](const char* key, int& field) {
    if (f.has(key)) field = required_positive_int(f, key);
  };
  positive_int("ORBextractor.nFeatures", orb.num_features);
  positive_int("ORBextractor.nLevels", orb.num_levels);
  positive_int("ORBextractor.iniThFAST", orb.ini_fast_threshold);
  positive_int("ORBextractor.minThFAST", orb.min_fast_threshold);
  if (const std::optional<double> scale = f.real("ORBextractor.scaleFactor")) {
    if (!(*scale > 1.0)) f.fail("ORBextractor.scaleFactor", "must be greater than 1, got " + format_number(*scale));
    orb.scale_factor = *scale;
  }
}

// Stereo: a second camera with its extrinsics, or a rectified pair given by its baseline.
void read_stereo(const SettingsFile& f, const Layout& layout, OrbSlamSettings& s) {
  SensorRig& rig = s.rig;
  double baseline_m = 0.0;
  if (layout.fisheye && (!layout.v1 || layout.rectified)) {
    f.fail("Camera.type", "a KannalaBrandt8 stereo pair needs Camera2.* and Stereo.T_c1_c2 (File.version \"1.0\")");
  }
  if (!layout.v1) {
    // Camera.* of such a file is the rectified camera the LEFT/RIGHT maps produce, not the images'
    // own: read as a rectified pair, raw images were stereo-matched as if rectified.
    for (const char* key : {"LEFT.K", "RIGHT.K", "LEFT.P", "RIGHT.P"}) {
      if (f.has(key)) {
        f.fail(key, "the old layout's rectification (LEFT.*/RIGHT.* K, D, R, P) is not supported: give the raw "
                    "cameras as Camera1.*/Camera2.* with Stereo.T_c1_c2 (File.version \"1.0\")");
      }
    }
    rig.bf = required_positive(f, "Camera.bf", "baseline times fx");
    baseline_m = rig.bf / rig.cam0.fx();
  } else if (layout.rectified) {
    baseline_m = required_positive(f, "Stereo.b", "baseline");
    // ORB-SLAM3 takes a Rectified camera as an ideal pinhole and ignores distortion keys; read here, they
    // would have the images rectified a second time (another focal length, another bf).
    const Distortion& d = rig.cam0.distortion();
    const std::pair<const char*, double> coefficients[] = {{"Camera1.k1", d.k1}, {"Camera1.k2", d.k2}, {"Camera1.p1", d.p1},
                                                           {"Camera1.p2", d.p2}, {"Camera1.k3", d.k3}};
    for (const auto& [key, value] : coefficients) {
      if (value != 0.0) {
        f.fail(key, "a \"Rectified\" camera is an ideal pinhole (ORB-SLAM3 ignores its distortion): remove the "
                    "distortion keys, or give the raw cameras as PinHole with Camera2.* and Stereo.T_c1_c2");
      }
    }
    rig.bf = baseline_m * rig.cam0.fx();
  } else {
    rig.cam1 = read_camera(f, "Camera2.", rig.cam0.width(), rig.cam0.height(), layout.fisheye);
    rig.T_cam0_cam1 = f.required(f.rigid("Stereo.T_c1_c2"), "Stereo.T_c1_c2");
    const double norm = rig.T_cam0_cam1.translation().norm();
    if (!(norm > 0.0)) f.fail("Stereo.T_c1_c2", "baseline (translation) must be non-zero");
    rig.bf = norm * rig.cam0.fx();
    return;
  }
  rig.cam1 = rig.cam0;
  rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
  rig.T_cam0_cam1.translation() = Eigen::Vector3d(baseline_m, 0.0, 0.0);
}

void read_rgbd(const SettingsFile& f, const Layout& layout, OrbSlamSettings& s) {
  s.rig.depth_scale = required_positive(f, layout.depth_map_factor, "depth map factor");
  if (layout.v1) {
    s.rig.bf = required_positive(f, "Stereo.b", "virtual baseline") * s.rig.cam0.fx();
  } else {
    s.rig.bf = required_positive(f, "Camera.bf", "virtual baseline times fx");
  }
}

void read_imu(const SettingsFile& f, const Layout& layout, SensorRig& rig) {
  // Either name of the camera-in-body pose is accepted; a missing one is reported by the layout's name.
  const std::string alternative = layout.v1 ? "Tbc" : "IMU.T_b_c1";
  const std::string key = !f.has(layout.T_body_cam0) && f.has(alternative) ? alternative : layout.T_body_cam0;
  rig.T_body_cam0 = f.required(f.rigid(key), key);
  ImuNoise imu;
  imu.gyro_noise_density = required_positive(f, "IMU.NoiseGyro", "noise density");
  imu.accel_noise_density = required_positive(f, "IMU.NoiseAcc", "noise density");
  imu.gyro_random_walk = required_positive(f, "IMU.GyroWalk", "random walk");
  imu.accel_random_walk = required_positive(f, "IMU.AccWalk", "random walk");
  imu.rate_hz = required_positive(f, "IMU.Frequency", "rate");
  rig.imu = imu;
}


// ---- writing -------------------------------------------------------------------------------------

// The shortest decimal that reads back as the same double, in real form ("500.0", not "500"): OpenCV
// types "500" as an integer, and older ORB-SLAM3 releases reject an integer where they read a float.
std::string real_text(double value) {
  std::string text = dataset_detail::exact(value);
  if (text.find_first_of(".eEn") == std::string::npos) text += ".0";  // 'n': inf and nan
  return text;
}

// The text of a settings file, key by key.
class SettingsText {
 public:
  SettingsText() { out_ << "%YAML:1.0\n"; }

  void comment(const std::string& text) { out_ << "\n# " << text << "\n"; }
  void text(const std::string& key, const std::string& value) { out_ << key << ": \"" << value << "\"\n"; }
  void integer(const std::string& key, long long value) { out_ << key << ": " << value << "\n"; }
  void real(const std::string& key, double value) { out_ << key << ": " << real_text(value) << "\n"; }

  // A rigid transformation as a 4x4 !!opencv-matrix. dt f is what ORB-SLAM3 reads (it takes the
  // entries as floats); the 17-digit text keeps the double for read_orbslam_settings.
  void matrix(const std::string& key, const Eigen::Isometry3d& T) {
    out_ << key << ": !!opencv-matrix\n  rows: 4\n  cols: 4\n  dt: f\n  data: [";
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        out_ << real_text(T.matrix()(r, c)) << (r == 3 && c == 3 ? "]\n" : c == 3 ? ",\n         " : ", ");
      }
    }
  }

  std::string str() const { return out_.str(); }

 private:
  std::ostringstream out_;
};

// Checks of what a file must hold to read back; `fail` names the file and the key.
class WriteChecks {
 public:
  explicit WriteChecks(const std::filesystem::path& file) : name_(file.string()) {}
  void require(bool condition, const std::string& key, const std::string& why) const {
    if (!condition) throw InputError(name_ + ":" + key, "cannot write the settings: " + why);
  }

 private:
  std::string name_;
};

// Inertial modes carry their IMU; RGB-D may (ORB-SLAM3's IMU_RGBD). A monocular or stereo rig's IMU is
// left out: its keys would make the file read back as the inertial mode.
bool writes_imu(const SensorRig& rig) {
  return is_inertial(rig.mode) || (rig.mode == SensorMode::kRgbd && rig.imu && rig.T_body_cam0);
}

void check_writable(const WriteChecks& check, const OrbSlamSettings& s) {
  const SensorRig& rig = s.rig;
  if (is_stereo(rig.mode)) {
    check.require(rig.cam1.has_value(), "Camera2.fx", "a stereo rig needs cam1");
    check.require(rig.cam1->width() == rig.cam0.width() && rig.cam1->height() == rig.cam0.height(),
                  "Camera.width", "both cameras must have the same image size");
    check.require(rig.cam1->distortion().model == rig.cam0.distortion().model, "Camera.type",
                  "both cameras must use the same model (one Camera.type for both)");
  }
  if (is_stereo(rig.mode) || rig.mode == SensorMode::kRgbd) {
    check.require(s.th_depth > 0.0, "Stereo.ThDepth", "stereo and RGB-D need a positive th_depth");
  }
  if (rig.mode == SensorMode::kRgbd) {
    check.require(rig.bf > 0.0, "Stereo.b", "RGB-D needs a positive (virtual) bf");
    check.require(rig.depth_scale > 0.0, "RGBD.DepthMapFactor", "the depth scale must be positive");
  }
  if (is_inertial(rig.mode)) {
    check.require(rig.imu.has_value(), "IMU.NoiseGyro", "an inertial mode needs the IMU noise");
    check.require(rig.T_body_cam0.has_value(), "IMU.T_b_c1", "an inertial mode needs T_body_cam0");
  }
  if (writes_imu(rig)) {
    const ImuNoise& imu = *rig.imu;
    for (const auto& [key, value] : {std::pair<const char*, double>{"IMU.NoiseGyro", imu.gyro_noise_density},
                                     {"IMU.NoiseAcc", imu.accel_noise_density},
                                     {"IMU.GyroWalk", imu.gyro_random_walk},
                                     {"IMU.AccWalk", imu.accel_random_walk},
                                     {"IMU.Frequency", imu.rate_hz}}) {
      check.require(value > 0.0, key, "IMU noise and rate must be positive");
    }
  }
  check.require(rig.fps > 0.0, "Camera.fps", "the frame rate must be positive");
  check.require((s.new_width > 0) == (s.new_height > 0) && s.new_width >= 0 && s.new_height >= 0,
                "Camera.newWidth", "give both new_width and new_height, or neither");
}

void write_camera(SettingsText& out, const std::string& prefix, const PinholeCamera& camera) {
  out.real(prefix + "fx", camera.fx());
  out.real(prefix + "fy", camera.fy());
  out.real(prefix + "cx", camera.cx());
  out.real(prefix + "cy", camera.cy());
  const Distortion& d = camera.distortion();
  if (d.is_equidistant()) {  // Camera.type KannalaBrandt8
    out.real(prefix + "k1", d.k1);
    out.real(prefix + "k2", d.k2);
    out.real(prefix + "k3", d.k3);
    out.real(prefix + "k4", d.k4);
    return;
  }
  if (d.is_zero()) return;  // absent keys mean no distortion to both readers; ORB-SLAM3 skips undistorting
  out.real(prefix + "k1", d.k1);
  out.real(prefix + "k2", d.k2);
  out.real(prefix + "p1", d.p1);
  out.real(prefix + "p2", d.p2);
  out.real(prefix + "k3", d.k3);
}

bool same_intrinsics(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width() == b.width() && a.height() == b.height() && a.fx() == b.fx() && a.fy() == b.fy() &&
         a.cx() == b.cx() && a.cy() == b.cy();
}

// A rectified pair in ORB-SLAM3's sense: one ideal camera twice, the second along +x of the first.
bool is_rectified_pair(const SensorRig& rig) {
  const Eigen::Vector3d t = rig.T_cam0_cam1.translation();
  return rig.cam1 && same_intrinsics(rig.cam0, *rig.cam1) && rig.cam0.distortion().is_zero() &&
         rig.cam1->distortion().is_zero() && rig.T_cam0_cam1.linear() == Eigen::Matrix3d::Identity() &&
         t.y() == 0.0 && t.z() == 0.0 && t.x() > 0.0;
}

// A baseline b with b * fx == bf, as the readers compute bf from it. The quotient is within an ulp or
// two of such a b when one exists; otherwise the quotient itself (bf then reads back an ulp off).
double baseline_for(double bf, double fx) {
  const double quotient = bf / fx;
  double down = quotient;
  double up = quotient;
  for (int step = 0; step < 3; ++step) {
    if (down * fx == bf) return down;
    if (up * fx == bf) return up;
    down = std::nextafter(down, 0.0);
    up = std::nextafter(up, std::numeric_limits<double>::infinity());
  }
  return quotient;
}

void write_image_settings(SettingsText& out, const OrbSlamSettings& s) {
  out.integer("Camera.width", s.rig.cam0.width());
  out.integer("Camera.height", s.rig.cam0.height());
  if (s.new_width > 0 && s.new_height > 0) {
    out.integer("Camera.newWidth", s.new_width);
    out.integer("Camera.newHeight", s.new_height);
  }
  // ORB-SLAM3 reads the frame rate as an integer.
  const double fps = s.rig.fps;
  if (fps == std::floor(fps) && std::abs(fps) < 1e9) {
    out.integer("Camera.fps", static_cast<long long>(fps));
  } else {
    out.real("Camera.fps", fps);
  }
  out.integer("Camera.RGB", s.rig.rgb_order ? 1 : 0);
}

void write_stereo(SettingsText& out, const SensorRig& rig) {
  if (is_rectified_pair(rig)) {
    out.real("Stereo.b", rig.T_cam0_cam1.translation().x());
    return;
  }
  write_camera(out, "Camera2.", *rig.cam1);
  out.matrix("Stereo.T_c1_c2", rig.T_cam0_cam1);
  // ORB-SLAM3 requires, for a fisheye pair, the columns where the two images overlap (it exits without
  // them); the whole width, as its TUM-VI example, lets its stereo search look everywhere. (It builds
  // camera 2's model from Camera1.k1..k4, whatever Camera2.k* says; this project reads both.)
  if (rig.cam0.distortion().is_equidistant()) {
    out.integer("Camera1.overlappingBegin", 0);
    out.integer("Camera1.overlappingEnd", rig.cam0.width() - 1);
    out.integer("Camera2.overlappingBegin", 0);
    out.integer("Camera2.overlappingEnd", rig.cam1->width() - 1);
  }
}

void write_imu(SettingsText& out, const SensorRig& rig) {
  out.matrix("IMU.T_b_c1", *rig.T_body_cam0);
  out.real("IMU.NoiseGyro", rig.imu->gyro_noise_density);
  out.real("IMU.NoiseAcc", rig.imu->accel_noise_density);
  out.real("IMU.GyroWalk", rig.imu->gyro_random_walk);
  out.real("IMU.AccWalk", rig.imu->accel_random_walk);
  out.real("IMU.Frequency", rig.imu->rate_hz);
}

void write_orb_extractor(SettingsText& out, const OrbExtractorSettings& orb) {
  out.integer("ORBextractor.nFeatures", orb.num_features);
  out.real("ORBextractor.scaleFactor", orb.scale_factor);
  out.integer("ORBextractor.nLevels", orb.num_levels);
  out.integer("ORBextractor.iniThFAST", orb.ini_fast_threshold);
  out.integer("ORBextractor.minThFAST", orb.min_fast_threshold);
}

// ORB-SLAM3 exits when these are missing and its viewer runs; the values are those of its examples.
void write_viewer(SettingsText& out) {
  const std::pair<const char*, double> kViewer[] = {
      {"Viewer.KeyFrameSize", 0.05}, {"Viewer.KeyFrameLineWidth", 1.0}, {"Viewer.GraphLineWidth", 0.9},
      {"Viewer.PointSize", 2.0},     {"Viewer.CameraSize", 0.08},       {"Viewer.CameraLineWidth", 3.0},
      {"Viewer.ViewpointX", 0.0},    {"Viewer.ViewpointY", -0.7},       {"Viewer.ViewpointZ", -1.8},
      {"Viewer.ViewpointF", 500.0}};
  for (const auto& [key, value] : kViewer) out.real(key, value);
}

std::string settings_text(const OrbSlamSettings& s) {
  const SensorRig& rig = s.rig;
  SettingsText out;
  out.comment("ORB-SLAM3 settings (" + to_string(rig.mode) + "), written by fleetslam");
  out.text("File.version", "1.0");
  const bool rectified = is_stereo(rig.mode) && is_rectified_pair(rig);
  out.text("Camera.type", rectified ? "Rectified" : rig.cam0.distortion().is_equidistant() ? "KannalaBrandt8" : "PinHole");
  write_camera(out, "Camera1.", rig.cam0);
  write_image_settings(out, s);
  if (is_stereo(rig.mode)) write_stereo(out, rig);
  if (rig.mode == SensorMode::kRgbd) {
    out.real("RGBD.DepthMapFactor", rig.depth_scale);
    out.real("Stereo.b", baseline_for(rig.bf, rig.cam0.fx()));
  }
  if (s.th_depth > 0.0) out.real("Stereo.ThDepth", s.th_depth);
  if (writes_imu(rig)) {
    out.comment("IMU: noise densities (continuous time), camera 1 in the body (IMU) frame");
    write_imu(out, rig);
  }
  out.comment("ORB features");
  write_orb_extractor(out, s.orb);
  out.comment("Viewer");
  write_viewer(out);
  return out.str();
}

}  // namespace

void write_orbslam_settings(const std::filesystem::path& file, const OrbSlamSettings& s) {
  check_writable(WriteChecks(file), s);
  const std::string text = settings_text(s);
  std::ofstream out(file);
  out << text;
  out.close();
  if (!out) throw InputError(file.string(), "cannot write the settings file");
}

OrbSlamSettings read_orbslam_settings(const std::filesystem::path& file, std::optional<SensorMode> mode) {
  const SettingsFile f(file);
  const Layout layout = read_layout(f);
  OrbSlamSettings s;
  s.rig.mode = mode ? *mode : infer_mode(f, layout);

  const int width = required_positive_int(f, "Camera.width");
  const int height = required_positive_int(f, "Camera.height");
  s.rig.cam0 = read_camera(f, layout.cam0, width, height, layout.fisheye);
  read_image_settings(f, s);
  read_orb_extractor(f, s.orb);

  if (is_stereo(s.rig.mode)) read_stereo(f, layout, s);
  if (s.rig.mode == SensorMode::kRgbd) read_rgbd(f, layout, s);
  if (is_stereo(s.rig.mode) || s.rig.mode == SensorMode::kRgbd) {
    s.th_depth = required_positive(f, layout.th_depth, "depth threshold");
  } else if (const std::optional<double> th = f.real(layout.th_depth)) {
    s.th_depth = positive(f, layout.th_depth, *th, "depth threshold");
  }
  if (is_inertial(s.rig.mode) || has_imu_keys(f)) read_imu(f, layout, s.rig);
  return s;
}

}  // namespace fleetslam::core
