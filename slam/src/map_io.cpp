// Map files (format in map_io.hpp): encoding, bounded decoding, validation and field-by-field comparison.

#include "fleetslam/slam/map_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <new>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include "binary_io.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'F', 'S', 'M', 'A', 'P', '\0', '\0', '\1'};
constexpr std::size_t kHeaderBytes = 24;
constexpr std::uint32_t kSections = 5;
constexpr char kTags[kSections][5] = {"META", "KFRM", "MPTS", "CULL", "REPL"};

using binary::fnv1a;
using binary::Reader;
using binary::Writer;

void write_doubles(Writer& w, const std::vector<double>& v) {
  w.size(v.size());
  for (double x : v) w.f64(x);
}

std::vector<double> read_doubles(Reader& r, const char* what) {
  std::vector<double> v(r.count(8, what));
  for (double& x : v) x = r.f64();
  return v;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

bool same_doubles(const double* a, const double* b, std::size_t n) { return std::memcmp(a, b, n * sizeof(double)) == 0; }

bool same_pose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return same_doubles(a.data(), b.data(), 16); }

}  // namespace

// Map's private members, for the file and the comparison.
struct MapAccess {
  static void write_meta(Writer& w, const Map& m, std::uint64_t fingerprint);
  static void write_keyframe(Writer& w, const Keyframe& kf);
  static void write_frame(Writer& w, const Frame& f);
  static void write_point(Writer& w, const MapPoint& p);
  static void read_meta(Reader& r, Map& m, std::uint64_t& fingerprint, std::size_t& keyframes, std::size_t& points);
  static Keyframe read_keyframe(Reader& r);
  static Frame read_frame(Reader& r);
  static MapPoint read_point(Reader& r);
  static std::string encode(const Map& m, std::uint64_t fingerprint);
  static SavedMap decode(const std::string& data, const std::string& where);
  static std::string validate(const Map& m);
  static std::string difference(const Map& a, const Map& b);
};

// ---- encoding --------------------------------------------------------------------------------------

void MapAccess::write_meta(Writer& w, const Map& m, std::uint64_t fingerprint) {
  w.i64(m.next_keyframe_id_);
  w.i64(m.next_point_id_);
  w.u64(fingerprint);
  w.size(m.components_.size());
  for (int c : m.components_) w.i32(c);
  w.size(m.keyframes_.size());
  w.size(m.points_.size());
}

void MapAccess::write_frame(Writer& w, const Frame& f) {
  w.i64(f.id);
  w.i64(f.t_ns);
  const core::PinholeCamera& c = f.camera;
  FLEETSLAM_CHECK(!c.distortion().is_equidistant(), "map files hold frames of radial-tangential (undistorted) cameras");
  w.i32(c.width());
  w.i32(c.height());
  for (double v : {c.fx(), c.fy(), c.cx(), c.cy(), c.distortion().k1, c.distortion().k2, c.distortion().p1,
                   c.distortion().p2, c.distortion().k3}) {
    w.f64(v);
  }
  w.i32(f.pyramid.levels);
  w.f64(f.pyramid.scale_factor);
  for (const std::vector<double>* v : {&f.pyramid.scale, &f.pyramid.inv_scale, &f.pyramid.sigma2, &f.pyramid.inv_sigma2}) {
    write_doubles(w, *v);
  }
  w.f64(f.bf);
  w.f64(f.close_depth_m);
  for (double v : {f.bounds.min_u, f.bounds.max_u, f.bounds.min_v, f.bounds.max_v}) w.f64(v);
  const std::size_t n = f.size();
  FLEETSLAM_CHECK(f.keypoints.size() == n && f.level.size() == n && f.depth_m.size() == n && f.u_right.size() == n &&
                      f.map_points.size() == n && f.outlier.size() == n,
                  "save_map: a keyframe's per-feature vectors differ in size");
  FLEETSLAM_CHECK(static_cast<std::size_t>(f.descriptors.rows) == n || (n == 0 && f.descriptors.empty()),
                  "save_map: descriptor rows differ from the number of features");
  w.size(n);
  for (const cv::KeyPoint& k : f.keypoints) {
    for (float v : {k.pt.x, k.pt.y, k.size, k.angle, k.response}) w.f32(v);
    w.i32(k.octave);
    w.i32(k.class_id);
  }
  for (const Eigen::Vector2d& p : f.uv) {
    w.f64(p.x());
    w.f64(p.y());
  }
  for (int l : f.level) w.i32(l);
  for (std::size_t i = 0; i < n; ++i) {
    const Descriptor d = descriptor_row(f.descriptors, static_cast<int>(i));
    w.bytes(d.data(), d.size());
  }
  for (double v : f.depth_m) w.f64(v);
  for (double v : f.u_right) w.f64(v);
  for (MapPointId id : f.map_points) w.i64(id);
  for (bool o : f.outlier) w.u8(o ? 1 : 0);
  w.u8(f.T_world_cam ? 1 : 0);
  if (f.T_world_cam) w.pose(*f.T_world_cam);
}

void MapAccess::write_keyframe(Writer& w, const Keyframe& kf) {
  w.i64(kf.id);
  w.i64(kf.t_ns);
  w.i32(kf.component);
  w.u8(kf.root ? 1 : 0);
  w.u8(kf.connected ? 1 : 0);
  w.pose(kf.T_world_cam);
  write_frame(w, kf.frame);
  w.size(kf.bow.entries.size());
  for (const BowEntry& e : kf.bow.entries) {
    w.u32(e.word);
    w.f64(e.weight);
  }
  w.size(kf.bow_features.nodes.size());
  for (const FeatureNode& node : kf.bow_features.nodes) {
    w.u32(node.node);
    w.size(node.features.size());
    for (int i : node.features) w.i32(i);
  }
  w.size(kf.connections.size());
  for (const auto& [id, weight] : kf.connections) {
    w.i64(id);
    w.i32(weight);
  }
  w.size(kf.neighbours.size());
  for (const auto& [id, weight] : kf.neighbours) {
    w.i64(id);
    w.i32(weight);
  }
  w.i64(kf.parent);
  w.size(kf.children.size());
  for (KeyframeId id : kf.children) w.i64(id);
  w.size(kf.loop_edges.size());
  for (KeyframeId id : kf.loop_edges) w.i64(id);
}

void MapAccess::write_point(Writer& w, const MapPoint& p) {
  w.i64(p.id);
  w.vec3(p.position);
  w.bytes(p.descriptor.data(), p.descriptor.size());
  w.size(p.observations.size());
  for (const auto& [kf, feature] : p.observations) {
    w.i64(kf);
    w.i32(feature);
  }
  w.vec3(p.normal);
  w.f64(p.min_distance_m);
  w.f64(p.max_distance_m);
  w.i64(p.reference_keyframe);
  w.i64(p.first_keyframe);
  w.i32(p.visible);
  w.i32(p.found);
}

std::string MapAccess::encode(const Map& m, std::uint64_t fingerprint) {
  std::vector<Writer> sections(kSections);
  write_meta(sections[0], m, fingerprint);
  for (const auto& entry : m.keyframes_) write_keyframe(sections[1], entry.second);
  for (MapPointId id : m.point_ids()) write_point(sections[2], m.points_.at(id));
  std::vector<KeyframeId> culled;
  for (const auto& entry : m.culled_) culled.push_back(entry.first);
  std::sort(culled.begin(), culled.end());
  sections[3].size(culled.size());
  for (KeyframeId id : culled) {
    sections[3].i64(id);
    sections[3].i64(m.culled_.at(id).parent);
    sections[3].pose(m.culled_.at(id).T_parent_kf);
  }
  std::vector<std::pair<MapPointId, MapPointId>> replaced(m.replaced_by_.begin(), m.replaced_by_.end());
  std::sort(replaced.begin(), replaced.end());
  sections[4].size(replaced.size());
  for (const auto& [old_id, by] : replaced) {
    sections[4].i64(old_id);
    sections[4].i64(by);
  }
  std::size_t payload = 0;
  for (Writer& s : sections) payload += 16 + s.str().size();
  Writer out;
  out.bytes(kMagic, sizeof kMagic);
  out.u32(kMapFormatVersion);
  out.u32(kSections);
  out.size(payload);
  for (std::uint32_t i = 0; i < kSections; ++i) {
    out.bytes(kTags[i], 4);
    out.u32(0);
    out.size(sections[i].str().size());
    out.bytes(sections[i].str().data(), sections[i].str().size());
  }
  out.u64(fnv1a(out.str().data(), out.str().size()));
  return std::move(out.str());
}

// ---- decoding --------------------------------------------------------------------------------------

void MapAccess::read_meta(Reader& r, Map& m, std::uint64_t& fingerprint, std::size_t& keyframes, std::size_t& points) {
  m.next_keyframe_id_ = r.i64();
  m.next_point_id_ = r.i64();
  fingerprint = r.u64();
  const std::size_t components = r.count(4, "components");
  for (std::size_t i = 0; i < components; ++i) m.components_.insert(r.i32());
  keyframes = static_cast<std::size_t>(r.u64());
  points = static_cast<std::size_t>(r.u64());
}

Frame MapAccess::read_frame(Reader& r) {
  Frame f;
  f.id = r.i64();
  f.t_ns = r.i64();
  const int width = r.i32();
  const int height = r.i32();
  double c[9];
  for (double& v : c) v = r.f64();
  if (width != 0 || height != 0) {
    try {
      f.camera = core::PinholeCamera(width, height, c[0], c[1], c[2], c[3], core::Distortion{c[4], c[5], c[6], c[7], c[8]});
    } catch (const std::invalid_argument& e) {
      r.fail(std::string("keyframe camera: ") + e.what());
    }
  }
  f.pyramid.levels = r.i32();
  f.pyramid.scale_factor = r.f64();
  f.pyramid.scale = read_doubles(r, "pyramid scales");
  f.pyramid.inv_scale = read_doubles(r, "pyramid scales");
  f.pyramid.sigma2 = read_doubles(r, "pyramid scales");
  f.pyramid.inv_sigma2 = read_doubles(r, "pyramid scales");
  f.bf = r.f64();
  f.close_depth_m = r.f64();
  f.bounds.min_u = r.f64();
  f.bounds.max_u = r.f64();
  f.bounds.min_v = r.f64();
  f.bounds.max_v = r.f64();
  // 28 (keypoint) + 16 (uv) + 4 (level) + 32 (descriptor) + 8 + 8 (depth, u_right) + 8 (map point) + 1
  const std::size_t n = r.count(105, "features");
  f.keypoints.resize(n);
  for (cv::KeyPoint& k : f.keypoints) {
    k.pt.x = r.f32();
    k.pt.y = r.f32();
    k.size = r.f32();
    k.angle = r.f32();
    k.response = r.f32();
    k.octave = r.i32();
    k.class_id = r.i32();
  }
  f.uv.resize(n);
  for (Eigen::Vector2d& p : f.uv) {
    p.x() = r.f64();
    p.y() = r.f64();
  }
  f.level.resize(n);
  for (int& l : f.level) l = r.i32();
  if (n > 0) {
    f.descriptors.create(static_cast<int>(n), kDescriptorBytes, CV_8UC1);
    for (std::size_t i = 0; i < n; ++i) r.bytes(f.descriptors.ptr<std::uint8_t>(static_cast<int>(i)), kDescriptorBytes);
  }
  f.depth_m.resize(n);
  for (double& v : f.depth_m) v = r.f64();
  f.u_right.resize(n);
  for (double& v : f.u_right) v = r.f64();
  for (double v : {f.bounds.min_u, f.bounds.max_u, f.bounds.min_v, f.bounds.max_v}) {
    if (!std::isfinite(v)) r.fail("keyframe image bounds are not finite");
  }
  f.finalize();  // the grid, as the front end built it
  for (MapPointId& id : f.map_points) id = r.i64();
  for (std::size_t i = 0; i < n; ++i) f.outlier[i] = r.flag();
  if (r.flag()) f.T_world_cam = r.pose();
  return f;
}

Keyframe MapAccess::read_keyframe(Reader& r) {
  Keyframe kf;
  kf.id = r.i64();
  kf.t_ns = r.i64();
  kf.component = r.i32();
  kf.root = r.flag();
  kf.connected = r.flag();
  kf.T_world_cam = r.pose();
  kf.frame = read_frame(r);
  kf.bow.entries.resize(r.count(12, "BoW entries"));
  for (BowEntry& e : kf.bow.entries) {
    e.word = r.u32();
    e.weight = r.f64();
  }
  kf.bow_features.nodes.resize(r.count(12, "feature vector nodes"));
  for (FeatureNode& node : kf.bow_features.nodes) {
    node.node = r.u32();
    node.features.resize(r.count(4, "feature vector entries"));
    for (int& i : node.features) {
      i = r.i32();
      if (i < 0 || static_cast<std::size_t>(i) >= kf.frame.size()) r.fail("a feature vector entry is out of range");
    }
  }
  const std::size_t connections = r.count(12, "covisibility links");
  for (std::size_t i = 0; i < connections; ++i) {
    const KeyframeId id = r.i64();
    kf.connections[id] = r.i32();
  }
  kf.neighbours.resize(r.count(12, "neighbours"));
  for (auto& [id, weight] : kf.neighbours) {
    id = r.i64();
    weight = r.i32();
  }
  kf.parent = r.i64();
  const std::size_t children = r.count(8, "children");
  for (std::size_t i = 0; i < children; ++i) kf.children.insert(r.i64());
  const std::size_t loop_edges = r.count(8, "loop edges");
  for (std::size_t i = 0; i < loop_edges; ++i) kf.loop_edges.insert(r.i64());
  return kf;
}

MapPoint MapAccess::read_point(Reader& r) {
  MapPoint p;
  p.id = r.i64();
  p.position = r.vec3();
  r.bytes(p.descriptor.data(), p.descriptor.size());
  const std::size_t observations = r.count(12, "observations");
  for (std::size_t i = 0; i < observations; ++i) {
    const KeyframeId kf = r.i64();
    p.observations[kf] = r.i32();
  }
  p.normal = r.vec3();
  p.min_distance_m = r.f64();
  p.max_distance_m = r.f64();
  p.reference_keyframe = r.i64();
  p.first_keyframe = r.i64();
  p.visible = r.i32();
  p.found = r.i32();
  return p;
}

SavedMap MapAccess::decode(const std::string& data, const std::string& where) {
  if (data.size() >= sizeof kMagic && std::memcmp(data.data(), kMagic, 5) != 0) {
    throw InputError(where, "not a fleetslam map file (bad magic)");
  }
  if (data.size() < kHeaderBytes + 8) {
    throw InputError(where, "truncated: " + std::to_string(data.size()) + " bytes, less than a map file header");
  }
  if (std::memcmp(data.data(), kMagic, sizeof kMagic) != 0) throw InputError(where, "not a fleetslam map file (bad magic)");
  Reader header(data, sizeof kMagic, kHeaderBytes, where);
  const std::uint32_t version = header.u32();
  if (version != kMapFormatVersion) {
    throw InputError(where, "map format version " + std::to_string(version) + " is not supported (this build reads " +
                                std::to_string(kMapFormatVersion) + ")");
  }
  const std::uint32_t sections = header.u32();
  if (sections != kSections) throw InputError(where, "the header lists " + std::to_string(sections) + " sections, expected 5");
  const std::uint64_t payload = header.u64();
  if (payload > data.size() || data.size() - kHeaderBytes - 8 != payload) {
    throw InputError(where, std::string(data.size() < kHeaderBytes + 8 + payload ? "truncated" : "trailing bytes") + ": " +
                                std::to_string(data.size()) + " bytes, the header's payload size needs " +
                                std::to_string(kHeaderBytes + 8 + payload));
  }
  std::uint64_t stored = 0;
  for (int i = 0; i < 8; ++i) stored |= std::uint64_t{static_cast<unsigned char>(data[data.size() - 8 + static_cast<std::size_t>(i)])} << (8 * i);
  if (fnv1a(data.data(), data.size() - 8) != stored) throw InputError(where, "checksum mismatch: the file is corrupted");

  SavedMap saved;
  Map& m = saved.map;
  std::size_t pos = kHeaderBytes;
  const std::size_t end = data.size() - 8;
  std::size_t keyframes = 0, points = 0;
  for (std::uint32_t s = 0; s < kSections; ++s) {
    const std::string section = where + ": section " + kTags[s];
    Reader head(data, pos, end, section);
    char tag[4];
    head.bytes(tag, 4);
    if (std::memcmp(tag, kTags[s], 4) != 0) head.fail("missing (found another tag)");
    head.u32();
    const std::uint64_t size = head.u64();
    pos += 16;
    if (size > end - pos) head.fail("size " + std::to_string(size) + " runs past the end of the file");
    Reader r(data, pos, pos + static_cast<std::size_t>(size), section);
    pos += static_cast<std::size_t>(size);
    switch (s) {
      case 0: read_meta(r, m, saved.vocabulary_fingerprint, keyframes, points); break;
      case 1:
        for (std::size_t i = 0; i < keyframes; ++i) {
          Keyframe kf = read_keyframe(r);
          const KeyframeId id = kf.id;
          if (!m.keyframes_.emplace(id, std::move(kf)).second) r.fail("keyframe " + std::to_string(id) + " twice");
        }
        break;
      case 2:
        for (std::size_t i = 0; i < points; ++i) {
          MapPoint p = read_point(r);
          const MapPointId id = p.id;
          if (!m.points_.emplace(id, std::move(p)).second) r.fail("map point " + std::to_string(id) + " twice");
        }
        break;
      case 3: {
        const std::size_t n = r.count(8 * 18, "culled keyframes");
        for (std::size_t i = 0; i < n; ++i) {
          const KeyframeId id = r.i64();
          CulledKeyframe c;
          c.parent = r.i64();
          c.T_parent_kf = r.pose();
          m.culled_[id] = c;
        }
        break;
      }
      default: {
        const std::size_t n = r.count(16, "replaced points");
        for (std::size_t i = 0; i < n; ++i) {
          const MapPointId old_id = r.i64();
          m.replaced_by_[old_id] = r.i64();
        }
        break;
      }
    }
    if (!r.done()) r.fail("holds bytes beyond its content");
  }
  const std::string why = validate(m);
  if (!why.empty()) throw InputError(where, "inconsistent map: " + why);
  return saved;
}

// What the rest of the agent relies on without checking: links both ways, indices within the frames,
// references to live keyframes, levels within the pyramid.
constexpr int kMaxPyramidLevels = 64;

// A finite rotation (orthonormal, determinant +1) and translation: what a diverged solve saved as NaN,
// or a corrupt file repaired behind its checksum, is refused here instead of failing silently later.
bool rigid(const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0 &&
         T.matrix().row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 0.0);
}

bool all_finite(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
}

std::string MapAccess::validate(const Map& m) {
  for (const auto& [id, kf] : m.keyframes_) {
    const std::string at = "keyframe " + std::to_string(id);
    if (id < 0 || id >= m.next_keyframe_id_) return at + ": id beyond the id counter";
    if (m.culled_.count(id) > 0) return at + ": both live and culled";
    if (m.components_.count(kf.component) == 0) return at + ": unknown component";
    if (!rigid(kf.T_world_cam)) return at + ": pose is not a finite rigid transform";
    const Frame& f = kf.frame;
    const bool uv_finite = std::all_of(f.uv.begin(), f.uv.end(), [](const Eigen::Vector2d& uv) { return uv.allFinite(); });
    if (!uv_finite || !all_finite(f.depth_m) || !all_finite(f.u_right)) {
      return at + ": a feature's coordinates or depth are not finite";
    }
    // The pyramid is the one its levels and scale factor make (level predictions divide by the factor's
    // logarithm: a factor of 1 or NaN with more levels than one was undefined behaviour later).
    const ScalePyramid& pyramid = f.pyramid;
    if (pyramid.levels < 1 || pyramid.levels > kMaxPyramidLevels || !std::isfinite(pyramid.scale_factor) ||
        pyramid.scale_factor < 1.0 || (pyramid.levels > 1 && !(pyramid.scale_factor > 1.0))) {
      return at + ": pyramid levels or scale factor out of range";
    }
    const ScalePyramid expected = ScalePyramid::make(pyramid.levels, pyramid.scale_factor);
    if (pyramid.scale != expected.scale || pyramid.inv_scale != expected.inv_scale ||
        pyramid.sigma2 != expected.sigma2 || pyramid.inv_sigma2 != expected.inv_sigma2) {
      return at + ": pyramid scales disagree with its scale factor";
    }
    for (int level : f.level) {
      if (level < 0 || level >= f.pyramid.levels) return at + ": a feature level outside the pyramid";
    }
    for (std::size_t i = 0; i < f.size(); ++i) {
      const MapPointId pid = f.map_points[i];
      if (pid == kNoMapPoint) continue;
      const auto p = m.points_.find(pid);
      if (p == m.points_.end()) return at + ": feature " + std::to_string(i) + " holds an unknown point";
      const auto obs = p->second.observations.find(id);
      if (obs == p->second.observations.end() || obs->second != static_cast<int>(i)) {
        return at + ": feature " + std::to_string(i) + " and point " + std::to_string(pid) + " disagree";
      }
    }
    for (const auto& link : kf.connections) {
      if (m.keyframes_.count(link.first) == 0 || link.first == id) return at + ": a covisibility link to an unknown keyframe";
    }
    for (const auto& link : kf.neighbours) {
      if (m.keyframes_.count(link.first) == 0 || link.first == id) return at + ": a neighbour that is unknown";
    }
    if (kf.parent != -1 && (m.keyframes_.count(kf.parent) == 0 || kf.parent == id)) return at + ": unknown parent";
    for (KeyframeId child : kf.children) {
      if (m.keyframes_.count(child) == 0 || child == id) return at + ": unknown child";
    }
    for (KeyframeId other : kf.loop_edges) {
      const auto partner = m.keyframes_.find(other);
      if (partner == m.keyframes_.end() || other == id || partner->second.loop_edges.count(id) == 0) {
        return at + ": a loop edge to an unknown keyframe or one way only";
      }
    }
  }
  for (const auto& [id, p] : m.points_) {
    const std::string at = "map point " + std::to_string(id);
    if (id < 0 || id >= m.next_point_id_) return at + ": id beyond the id counter";
    if (p.observations.empty()) return at + ": no observation";
    if (!p.position.allFinite() || !p.normal.allFinite() || !std::isfinite(p.min_distance_m) ||
        !std::isfinite(p.max_distance_m)) {
      return at + ": position, viewing direction or distance range not finite";
    }
    for (const auto& [kf_id, feature] : p.observations) {
      const auto kf = m.keyframes_.find(kf_id);
      if (kf == m.keyframes_.end()) return at + ": observed by an unknown keyframe";
      if (feature < 0 || static_cast<std::size_t>(feature) >= kf->second.frame.size() ||
          kf->second.frame.map_points[static_cast<std::size_t>(feature)] != id) {
        return at + ": observation in keyframe " + std::to_string(kf_id) + " disagrees with the feature";
      }
    }
  }
  for (const auto& [id, c] : m.culled_) {
    if (c.parent != -1 && m.keyframes_.count(c.parent) == 0 && m.culled_.count(c.parent) == 0) {
      return "culled keyframe " + std::to_string(id) + ": unknown parent";
    }
    if (!rigid(c.T_parent_kf)) return "culled keyframe " + std::to_string(id) + ": pose is not a finite rigid transform";
  }
  return {};
}

// ---- comparison ------------------------------------------------------------------------------------

namespace {

std::string frame_difference(const Frame& a, const Frame& b) {
  if (a.id != b.id) return "frame.id";
  if (a.t_ns != b.t_ns) return "frame.t_ns";
  const core::PinholeCamera& ca = a.camera;
  const core::PinholeCamera& cb = b.camera;
  const double va[] = {ca.fx(), ca.fy(), ca.cx(), ca.cy(), ca.distortion().k1, ca.distortion().k2, ca.distortion().p1,
                       ca.distortion().p2, ca.distortion().k3};
  const double vb[] = {cb.fx(), cb.fy(), cb.cx(), cb.cy(), cb.distortion().k1, cb.distortion().k2, cb.distortion().p1,
                       cb.distortion().p2, cb.distortion().k3};
  if (ca.width() != cb.width() || ca.height() != cb.height() || !same_doubles(va, vb, 9)) return "frame.camera";
  const ScalePyramid& pa = a.pyramid;
  const ScalePyramid& pb = b.pyramid;
  if (pa.levels != pb.levels || !same_bits(pa.scale_factor, pb.scale_factor) || pa.scale.size() != pb.scale.size() ||
      pa.inv_scale.size() != pb.inv_scale.size() || pa.sigma2.size() != pb.sigma2.size() ||
      pa.inv_sigma2.size() != pb.inv_sigma2.size() || !same_doubles(pa.scale.data(), pb.scale.data(), pa.scale.size()) ||
      !same_doubles(pa.inv_scale.data(), pb.inv_scale.data(), pa.inv_scale.size()) ||
      !same_doubles(pa.sigma2.data(), pb.sigma2.data(), pa.sigma2.size()) ||
      !same_doubles(pa.inv_sigma2.data(), pb.inv_sigma2.data(), pa.inv_sigma2.size())) {
    return "frame.pyramid";
  }
  if (!same_bits(a.bf, b.bf)) return "frame.bf";
  if (!same_bits(a.close_depth_m, b.close_depth_m)) return "frame.close_depth_m";
  const double ba[] = {a.bounds.min_u, a.bounds.max_u, a.bounds.min_v, a.bounds.max_v};
  const double bb[] = {b.bounds.min_u, b.bounds.max_u, b.bounds.min_v, b.bounds.max_v};
  if (!same_doubles(ba, bb, 4)) return "frame.bounds";
  if (a.size() != b.size() || a.keypoints.size() != b.keypoints.size() || a.level.size() != b.level.size() ||
      a.depth_m.size() != b.depth_m.size() || a.u_right.size() != b.u_right.size() ||
      a.map_points.size() != b.map_points.size() || a.outlier.size() != b.outlier.size()) {
    return "frame feature counts";
  }
  for (std::size_t i = 0; i < a.keypoints.size(); ++i) {
    const cv::KeyPoint& x = a.keypoints[i];
    const cv::KeyPoint& y = b.keypoints[i];
    const float fx[] = {x.pt.x, x.pt.y, x.size, x.angle, x.response};
    const float fy[] = {y.pt.x, y.pt.y, y.size, y.angle, y.response};
    if (std::memcmp(fx, fy, sizeof fx) != 0 || x.octave != y.octave || x.class_id != y.class_id) {
      return "frame.keypoints[" + std::to_string(i) + "]";
    }
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!same_doubles(a.uv[i].data(), b.uv[i].data(), 2)) return "frame.uv[" + std::to_string(i) + "]";
    if (a.level[i] != b.level[i]) return "frame.level[" + std::to_string(i) + "]";
    if (!same_bits(a.depth_m[i], b.depth_m[i])) return "frame.depth_m[" + std::to_string(i) + "]";
    if (!same_bits(a.u_right[i], b.u_right[i])) return "frame.u_right[" + std::to_string(i) + "]";
    if (a.map_points[i] != b.map_points[i]) return "frame.map_points[" + std::to_string(i) + "]";
    if (a.outlier[i] != b.outlier[i]) return "frame.outlier[" + std::to_string(i) + "]";
  }
  if (a.descriptors.rows != b.descriptors.rows || a.descriptors.cols != b.descriptors.cols ||
      a.descriptors.type() != b.descriptors.type()) {
    return "frame.descriptors (shape)";
  }
  for (int i = 0; i < a.descriptors.rows; ++i) {
    if (descriptor_row(a.descriptors, i) != descriptor_row(b.descriptors, i)) return "frame.descriptors[" + std::to_string(i) + "]";
  }
  if (!(a.grid == b.grid)) return "frame.grid";
  if (a.T_world_cam.has_value() != b.T_world_cam.has_value() ||
      (a.T_world_cam && !same_pose(*a.T_world_cam, *b.T_world_cam))) {
    return "frame.T_world_cam";
  }
  return {};
}

std::string keyframe_difference(const Keyframe& a, const Keyframe& b) {
  if (a.id != b.id) return "id";
  if (a.t_ns != b.t_ns) return "t_ns";
  if (a.component != b.component) return "component";
  if (a.root != b.root) return "root";
  if (a.connected != b.connected) return "connected";
  if (!same_pose(a.T_world_cam, b.T_world_cam)) return "T_world_cam";
  if (std::string why = frame_difference(a.frame, b.frame); !why.empty()) return why;
  if (a.bow.entries.size() != b.bow.entries.size()) return "bow";
  for (std::size_t i = 0; i < a.bow.entries.size(); ++i) {
    if (a.bow.entries[i].word != b.bow.entries[i].word || !same_bits(a.bow.entries[i].weight, b.bow.entries[i].weight)) {
      return "bow";
    }
  }
  if (!(a.bow_features == b.bow_features)) return "bow_features";
  if (a.connections != b.connections) return "connections";
  if (a.neighbours != b.neighbours) return "neighbours";
  if (a.parent != b.parent) return "parent";
  if (a.children != b.children) return "children";
  if (a.loop_edges != b.loop_edges) return "loop_edges";
  return {};
}

std::string point_difference(const MapPoint& a, const MapPoint& b) {
  if (a.id != b.id) return "id";
  if (!same_doubles(a.position.data(), b.position.data(), 3)) return "position";
  if (a.descriptor != b.descriptor) return "descriptor";
  if (a.observations != b.observations) return "observations";
  if (!same_doubles(a.normal.data(), b.normal.data(), 3)) return "normal";
  if (!same_bits(a.min_distance_m, b.min_distance_m) || !same_bits(a.max_distance_m, b.max_distance_m)) return "distances";
  if (a.reference_keyframe != b.reference_keyframe) return "reference_keyframe";
  if (a.first_keyframe != b.first_keyframe) return "first_keyframe";
  if (a.visible != b.visible || a.found != b.found) return "visible/found";
  return {};
}

}  // namespace

std::string MapAccess::difference(const Map& a, const Map& b) {
  if (a.next_keyframe_id_ != b.next_keyframe_id_) return "keyframe id counter";
  if (a.next_point_id_ != b.next_point_id_) return "map point id counter";
  if (a.components_ != b.components_) return "components";
  if (a.keyframes_.size() != b.keyframes_.size()) return "keyframe count";
  for (const auto& [id, kf] : a.keyframes_) {
    const auto other = b.keyframes_.find(id);
    if (other == b.keyframes_.end()) return "keyframe " + std::to_string(id) + " missing";
    if (std::string why = keyframe_difference(kf, other->second); !why.empty()) {
      return "keyframe " + std::to_string(id) + ": " + why + " differs";
    }
  }
  if (a.points_.size() != b.points_.size()) return "map point count";
  for (const auto& [id, p] : a.points_) {
    const auto other = b.points_.find(id);
    if (other == b.points_.end()) return "map point " + std::to_string(id) + " missing";
    if (std::string why = point_difference(p, other->second); !why.empty()) {
      return "map point " + std::to_string(id) + ": " + why + " differs";
    }
  }
  if (a.culled_.size() != b.culled_.size()) return "culled keyframe count";
  for (const auto& [id, c] : a.culled_) {
    const auto other = b.culled_.find(id);
    if (other == b.culled_.end() || other->second.parent != c.parent || !same_pose(other->second.T_parent_kf, c.T_parent_kf)) {
      return "culled keyframe " + std::to_string(id) + " differs";
    }
  }
  if (a.replaced_by_ != b.replaced_by_) return "replaced points";
  return {};
}

// ---- public functions ------------------------------------------------------------------------------

std::uint64_t vocabulary_fingerprint(const Vocabulary& vocabulary) {
  if (vocabulary.empty()) return 0;
  const VocabularyTree& t = vocabulary.tree();
  Writer w;
  w.i32(t.branching);
  w.i32(t.depth_levels);
  for (NodeId p : t.parent) w.u32(p);
  w.bytes(t.descriptors.data(), t.descriptors.size());
  for (WordId id : t.word) w.u32(id);
  for (double weight : t.word_weight) w.f64(weight);
  const std::uint64_t hash = fnv1a(w.str().data(), w.str().size());
  return hash == 0 ? 1 : hash;
}

std::string map_to_bytes(const Map& map, std::uint64_t fingerprint) { return MapAccess::encode(map, fingerprint); }

SavedMap map_from_bytes(const std::string& bytes, const std::string& where) {
  try {
    return MapAccess::decode(bytes, where);
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(where, "sizes too large to load");
  } catch (const std::exception& e) {
    throw InputError(where, std::string("inconsistent map: ") + e.what());
  }
}

// Written beside the file, then renamed over it: a full disk or a crash mid-write leaves an earlier map
// at `file` whole.
void save_map(const Map& map, const fs::path& file, std::uint64_t fingerprint) {
  const std::string data = map_to_bytes(map, fingerprint);
  fs::path partial = file;
  partial += ".partial";
  {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(file.string(), "cannot open the map file for writing (" + partial.string() + ")");
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    out.close();
    if (!out) {
      std::error_code ec;
      fs::remove(partial, ec);
      throw InputError(file.string(), "cannot write the map file");
    }
  }
  std::error_code ec;
  fs::rename(partial, file, ec);
  if (ec) {
    fs::remove(partial, ec);
    throw InputError(file.string(), "cannot replace the map file: " + ec.message());
  }
}

SavedMap load_map(const fs::path& file) {
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw InputError(file.string(), "a folder, not a map file");
  if (!fs::exists(file, ec)) throw InputError(file.string(), "map file not found");
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(file.string(), "cannot open the map file");
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(file.string(), "cannot read the map file");
  std::string data(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  in.read(data.data(), static_cast<std::streamsize>(size));
  if (!in) throw InputError(file.string(), "cannot read the map file");
  return map_from_bytes(data, file.string());
}

std::string map_difference(const Map& a, const Map& b) { return MapAccess::difference(a, b); }

}  // namespace fleetslam::slam
