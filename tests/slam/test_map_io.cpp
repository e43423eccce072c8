// Map files: an agent's map of the synthetic room saves and loads back identical in every field; a second
// run in localisation-only mode on the same sequence localises every frame in the loaded map with an ATE
// like the first run's and inserts no keyframe; truncated, corrupted, foreign and wrong-version files are
// InputErrors naming the file, never a crash (random truncations and byte flips, with and without a
// repaired checksum).

#include <gtest/gtest.h>


#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/slam/agent.hpp"
#include "fleetslam/slam/map_io.hpp"
#include "synthetic_room.hpp"

namespace fleetslam::slam {
namespace {

namespace fs = std::filesystem;

constexpr int kFrames = 90;

const std::vector<core::SensorFrame>& sequence() {
  static const std::vector<core::SensorFrame> frames = [] {
    const test::SyntheticRoom room = test::default_room();
    const core::SensorRig rig = test::synthetic_rgbd_rig();
    std::vector<core::SensorFrame> out;
    for (int i = 0; i < kFrames; ++i) out.push_back(test::synthetic_frame(room, rig, i));
    return out;
  }();
  return frames;
}

fs::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::temp_directory_path() / "fleetslam_test_map_io" / info->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct FirstRun {
  Map map;
  std::string bytes;  // as Agent::save_map wrote them
  core::Trajectory trajectory;
};

// The agent's run over the sequence and its saved map, once for every test.
const FirstRun& first_run() {
  static const FirstRun run = [] {
    Agent agent(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
    for (const core::SensorFrame& f : sequence()) agent.process(f);
    agent.finish();
    const fs::path file = fs::temp_directory_path() / "fleetslam_test_map_io_first.fsmap";
    agent.save_map(file);
    FirstRun r;
    r.map = agent.map_copy();
    std::ifstream in(file, std::ios::binary | std::ios::ate);
    r.bytes.resize(static_cast<std::size_t>(in.tellg()));
    in.seekg(0);
    in.read(r.bytes.data(), static_cast<std::streamsize>(r.bytes.size()));
    r.trajectory = agent.trajectory();
    fs::remove(file);
    return r;
  }();
  return run;
}

double ate_rmse(const core::Trajectory& estimate, core::AlignmentMode mode) {
  core::Trajectory gt;
  for (const core::SensorFrame& f : sequence()) gt.push_back(core::StampedPose{f.t_ns, *f.T_world_cam_gt});
  return core::compute_ate(gt, estimate, core::associate_by_time(gt, estimate), mode).stats.rmse;
}

std::uint64_t fnv1a(const std::string& data, std::size_t size) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(data[i]);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

// The trailing checksum made right again for the bytes before it.
void repair_checksum(std::string& data) {
  const std::uint64_t sum = fnv1a(data, data.size() - 8);
  for (int i = 0; i < 8; ++i) data[data.size() - 8 + static_cast<std::size_t>(i)] = static_cast<char>((sum >> (8 * i)) & 0xFF);
}

void write_bytes(const fs::path& file, const std::string& data) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
}

// The InputError's message for loading `data` from a file, or "" when it loads.
std::string load_error(const fs::path& file, const std::string& data) {
  write_bytes(file, data);
  try {
    load_map(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(MapIo, AgentMapRoundTripPreservesEveryField) {
  const FirstRun& run = first_run();
  const Map& map = run.map;
  ASSERT_GT(map.keyframe_count(), 3u);
  ASSERT_GT(map.point_count(), 1000u);
  int culled = 0, with_bow = 0, connected = 0;
  for (KeyframeId id = 0; map.keyframe(id) != nullptr || map.is_culled(id); ++id) culled += map.is_culled(id) ? 1 : 0;
  for (const auto& [id, kf] : map.keyframes()) {
    with_bow += kf.bow.empty() ? 0 : 1;
    connected += kf.neighbours.empty() ? 0 : 1;
  }
  std::printf("map: %zu keyframes (%d culled), %zu points, file %zu bytes\n", map.keyframe_count(), culled,
              map.point_count(), run.bytes.size());
  EXPECT_EQ(with_bow, static_cast<int>(map.keyframe_count()));
  EXPECT_EQ(connected, static_cast<int>(map.keyframe_count()));

  const fs::path file = test_dir() / "map.fsmap";
  write_bytes(file, run.bytes);
  const SavedMap loaded = load_map(file);
  EXPECT_EQ(map_difference(map, loaded.map), "");
  EXPECT_NE(loaded.vocabulary_fingerprint, 0u);
  EXPECT_EQ(loaded.vocabulary_fingerprint, vocabulary_fingerprint(*load_place_vocabulary(PlaceRecognitionConfig{})));
  // Saving the loaded map gives the same bytes.
  EXPECT_TRUE(map_to_bytes(loaded.map, loaded.vocabulary_fingerprint) == run.bytes);
  // Culled keyframes still hand their poses on.
  for (KeyframeId id = 0; id < static_cast<KeyframeId>(map.keyframe_count()) + culled; ++id) {
    const auto a = map.keyframe_pose(id);
    const auto b = loaded.map.keyframe_pose(id);
    ASSERT_EQ(a.has_value(), b.has_value());
    if (a) {
      EXPECT_TRUE(a->matrix() == b->matrix());
    }
  }
}

// The agent's short run culls nothing: cull a keyframe and fuse two points here, then round trip.
TEST(MapIo, RoundTripKeepsCulledKeyframesAndReplacedPoints) {
  Map map = first_run().map;
  KeyframeId victim = -1;
  for (const auto& [id, kf] : map.keyframes()) {
    if (!kf.root && kf.children.empty() == false) victim = id;
  }
  if (victim < 0) victim = map.keyframes().rbegin()->first;
  ASSERT_TRUE(map.erase_keyframe(victim));
  const std::vector<MapPointId> ids = map.point_ids();
  map.replace_map_point(ids[ids.size() / 2], ids[ids.size() / 2 + 1]);
  ASSERT_TRUE(map.is_culled(victim));
  const SavedMap loaded = map_from_bytes(map_to_bytes(map, 42), "memory");
  EXPECT_EQ(loaded.vocabulary_fingerprint, 42u);
  EXPECT_EQ(map_difference(map, loaded.map), "");
  EXPECT_EQ(loaded.map.resolve(ids[ids.size() / 2]), ids[ids.size() / 2 + 1]);
  ASSERT_TRUE(loaded.map.keyframe_pose(victim).has_value());
  EXPECT_TRUE(loaded.map.keyframe_pose(victim)->matrix() == map.keyframe_pose(victim)->matrix());
}

TEST(MapIo, RoundTripKeepsLoopEdges) {
  Map map = first_run().map;
  const KeyframeId first = map.keyframes().begin()->first;
  const KeyframeId last = map.keyframes().rbegin()->first;
  ASSERT_TRUE(map.add_loop_edge(last, first));
  const SavedMap loaded = map_from_bytes(map_to_bytes(map, 0), "memory");
  EXPECT_EQ(map_difference(map, loaded.map), "");
  EXPECT_EQ(loaded.map.keyframe(first)->loop_edges, std::set<KeyframeId>{last});
  EXPECT_EQ(loaded.map.keyframe(last)->loop_edges, std::set<KeyframeId>{first});
  Map one_way = map;
  one_way.keyframe(first)->loop_edges.clear();
  EXPECT_NE(map_difference(map, one_way).find("loop_edges"), std::string::npos);
  // A file whose loop edge goes one way only is refused.
  EXPECT_THROW(map_from_bytes(map_to_bytes(one_way, 0), "memory"), InputError);
}

TEST(MapIo, ComparisonSeesASingleChangedField) {
  const FirstRun& run = first_run();
  const KeyframeId kf = run.map.keyframes().rbegin()->first;
  const MapPointId point = run.map.point_ids().back();
  {
    Map changed = run.map;
    changed.point(point)->visible += 1;
    EXPECT_NE(map_difference(run.map, changed), "");
  }
  {
    Map changed = run.map;
    Eigen::Vector2d& uv = changed.keyframe(kf)->frame.uv[0];
    uv.x() = std::nextafter(uv.x(), 1e9);
    EXPECT_NE(map_difference(run.map, changed).find("frame.uv[0]"), std::string::npos);
  }
  {
    Map changed = run.map;
    cv::Mat& descriptors = changed.keyframe(kf)->frame.descriptors;
    descriptors = descriptors.clone();  // cv::Mat copies share their pixels
    descriptors.at<std::uint8_t>(3, 7) ^= 1;
    EXPECT_NE(map_difference(run.map, changed).find("descriptors"), std::string::npos);
  }
  {
    Map changed = run.map;
    changed.keyframe(kf)->bow.entries.front().weight *= 1.0 + 1e-15;
    EXPECT_NE(map_difference(run.map, changed), "");
  }
}

// A localisation-only agent on `map_file` over the sequence: the first frame must relocalise; returns the
// frames tracked. Every update must leave the map as it is.
int localize_in(Agent& agent) {
  int tracked = 0;
  for (const core::SensorFrame& f : sequence()) {
    const AgentUpdate u = agent.process(f);
    if (f.sequence == 0) {
      EXPECT_TRUE(u.relocalized) << u.reason;
    }
    tracked += u.status == FrameStatus::kTracked ? 1 : 0;
    EXPECT_TRUE(u.new_keyframes.empty());
    EXPECT_TRUE(u.removed_keyframes.empty());
    EXPECT_TRUE(u.loops.empty());
  }
  agent.finish();
  return tracked;
}

AgentConfig localization_only(const fs::path& map_file) {
  AgentConfig config;
  config.load_map = map_file.string();
  config.localization_only = true;
  return config;
}

TEST(MapIo, LocalizationOnlyRunLocalisesEveryFrameInTheLoadedMap) {
  const FirstRun& run = first_run();
  const fs::path file = test_dir() / "map.fsmap";
  write_bytes(file, run.bytes);
  Agent agent(localization_only(file), test::synthetic_rgbd_rig(), core::null_logger());
  EXPECT_EQ(localize_in(agent), kFrames);
  const MapStats stats = agent.map_stats();
  EXPECT_EQ(stats.keyframes, run.map.keyframe_count());
  EXPECT_EQ(stats.points, run.map.point_count());
  const core::Trajectory trajectory = agent.trajectory();
  ASSERT_EQ(trajectory.size(), static_cast<std::size_t>(kFrames));
  const double first = ate_rmse(run.trajectory, core::AlignmentMode::kSe3);
  const double second = ate_rmse(trajectory, core::AlignmentMode::kSe3);
  // The loaded map keeps the first run's world frame: no alignment needed.
  const double second_world = ate_rmse(trajectory, core::AlignmentMode::kNone);
  std::printf("ATE RMSE: first run %.5f m, localisation only %.5f m (%.5f m without alignment)\n", first, second,
              second_world);
  EXPECT_LT(second, 2.0 * first + 0.002);
  EXPECT_LT(second_world, 2.0 * first + 0.005);
}

// A saved map whose newest component is a short one (made after a loss, elsewhere): a localisation-only
// run from the start of the route relocalises in the older component (it was looked for in the newest
// one only, and stayed lost for the whole run).
TEST(MapIo, ALoadedMapIsSearchedInAllItsComponents) {
  const FirstRun& run = first_run();
  Map map = run.map;
  const Keyframe& first = map.keyframes().begin()->second;
  Eigen::Isometry3d far_away = first.T_world_cam;
  far_away.translation() += Eigen::Vector3d(30.0, 0.0, 0.0);
  const int component = first.component + 1;
  const KeyframeId newest = map.add_keyframe(first.frame, far_away, component);  // its features have no points
  ASSERT_EQ(map.keyframes().rbegin()->first, newest);
  const fs::path file = test_dir() / "two_components.fsmap";
  save_map(map, file, 0);
  AgentConfig config = localization_only(file);
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  EXPECT_EQ(localize_in(agent), kFrames);

  // Mapping on from there, then lost among frames the map has never seen: the new component comes after
  // both of the file's, not after the one the camera was placed in (it would have joined the far one).
  config.localization_only = false;
  config.tracking.relocalization.new_map_after_s = 0.1;
  Agent mapping(config, test::synthetic_rgbd_rig(), core::null_logger());
  ASSERT_TRUE(mapping.process(sequence()[0]).relocalized);
  cv::RNG rng(7);
  for (int i = 1; i < 12; ++i) {
    core::SensorFrame unseen = sequence()[static_cast<std::size_t>(i)];
    unseen.image = cv::Mat(unseen.image.size(), unseen.image.type());
    rng.fill(unseen.image, cv::RNG::UNIFORM, 0, 256);
    mapping.process(unseen);
  }
  const Map after = mapping.map_copy();
  ASSERT_GT(after.keyframe_count(), map.keyframe_count()) << "a new map started";
  EXPECT_EQ(after.keyframes().rbegin()->second.component, component + 1);

  mapping.finish();

  // Never placed in the loaded map: the new component started among unseen frames is not the loaded map.
  // Lost in it, the camera relocalises within it only, never in the file's components (whose poses are in
  // another frame: the trajectory would jump between them).
  Agent stranger(config, test::synthetic_rgbd_rig(), core::null_logger());
  int newest_component = -1;
  for (int i = 0; i < 12; ++i) {
    core::SensorFrame unseen = sequence()[static_cast<std::size_t>(i)];
    unseen.image = cv::Mat(unseen.image.size(), unseen.image.type());
    rng.fill(unseen.image, cv::RNG::UNIFORM, 0, 256);
    newest_component = std::max(newest_component, stranger.process(unseen).component);
  }
  ASSERT_GT(newest_component, component) << "a component of its own started";
  for (int i = 12; i < 40; ++i) {
    const AgentUpdate u = stranger.process(sequence()[static_cast<std::size_t>(i)]);
    EXPECT_FALSE(u.relocalized) << "frame " << i << ": " << u.reason;
    EXPECT_EQ(u.reason.find("loaded map"), std::string::npos) << "frame " << i << ": " << u.reason;
  }
  stranger.finish();
}

// A map made with one vocabulary, loaded by an agent with another: the BoW vectors are recomputed with
// the agent's, and relocalisation still finds the map.
TEST(MapIo, LoadingWithAnotherVocabularyRecomputesBow) {
  const FirstRun& run = first_run();
  const fs::path dir = test_dir();
  std::vector<cv::Mat> training;
  for (const auto& [id, kf] : run.map.keyframes()) training.push_back(kf.frame.descriptors);
  VocabularyConfig small;
  small.branching = 6;
  small.depth_levels = 3;
  const Vocabulary other = VocabularyTrainer(small).train(training);
  other.save(dir / "other.fsvoc");
  write_bytes(dir / "map.fsmap", run.bytes);
  AgentConfig config;
  config.place_recognition.vocabulary = (dir / "other.fsvoc").string();
  config.localization_only = true;
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  agent.load_map(dir / "map.fsmap");
  const Map map = agent.map_copy();
  for (const auto& [id, kf] : map.keyframes()) {
    const BowTransform expected = other.transform(kf.frame.descriptors, config.place_recognition.levels_up);
    EXPECT_TRUE(kf.bow == expected.bow) << "keyframe " << id;
    EXPECT_TRUE(kf.bow_features == expected.features) << "keyframe " << id;
  }
  int tracked = 0;
  for (int i = 0; i < 10; ++i) tracked += agent.process(sequence()[static_cast<std::size_t>(i)]).has_pose() ? 1 : 0;
  EXPECT_EQ(tracked, 10);
  EXPECT_EQ(agent.map_stats().keyframes, run.map.keyframe_count());
}

// A map made with another camera is refused, naming the file: bundle adjustment projects a window's
// keyframes with the agent's camera, and the map's observations would have been rejected as outliers.
TEST(MapIo, AMapOfAnotherCameraIsRefused) {
  const fs::path file = test_dir() / "map.fsmap";
  write_bytes(file, first_run().bytes);
  core::SensorRig other = test::synthetic_rgbd_rig();
  other.cam0 = core::PinholeCamera(other.cam0.width(), other.cam0.height(), other.cam0.fx() * 1.03, other.cam0.fy() * 1.03,
                                   other.cam0.cx(), other.cam0.cy());
  Agent agent(AgentConfig{}, other, core::null_logger());
  try {
    agent.load_map(file);
    FAIL() << "loaded";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": keyframe", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("another camera"), std::string::npos) << e.what();
  }
  core::SensorRig wider = test::synthetic_rgbd_rig();
  wider.bf = 45.0;  // another baseline
  Agent baseline(AgentConfig{}, wider, core::null_logger());
  EXPECT_THROW(baseline.load_map(file), InputError);
  Agent same(AgentConfig{}, test::synthetic_rgbd_rig(), core::null_logger());
  EXPECT_NO_THROW(same.load_map(file));
}

// A localisation-only agent with `config` (localization_only set here) in the first run's saved map.
Agent localising_in_first_map(AgentConfig config) {
  const fs::path file = test_dir() / "map.fsmap";
  write_bytes(file, first_run().bytes);
  config.localization_only = true;
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  agent.load_map(file);
  return agent;
}

// The map's BoW vectors follow the loading agent's place_recognition.levels_up: grouped at another tree
// depth they shared no node with its frames, and relocalisation silently never succeeded.
TEST(MapIo, LoadingWithAnotherLevelsUpRelocalises) {
  AgentConfig config;
  config.place_recognition.levels_up = AgentConfig{}.place_recognition.levels_up + 2;
  Agent agent = localising_in_first_map(config);
  const AgentUpdate first = agent.process(sequence().front());
  EXPECT_TRUE(first.relocalized) << first.reason;
  EXPECT_NE(first.reason.find("relocalised in the loaded map"), std::string::npos) << first.reason;
  // This session's clock starts at its first frame: T_I was that frame's absolute stamp.
  ASSERT_TRUE(first.keyframe_decision.has_value());
  for (const auto& [name, value] : first.keyframe_decision->factors) {
    if (name == "T_I") {
      EXPECT_LT(value, 1.0);
    }
  }
  EXPECT_FALSE(first.keyframe_decision->insert) << "localisation only";
  const Map map = agent.map_copy();
  ASSERT_FALSE(map.keyframes().empty());
  for (const auto& [id, kf] : map.keyframes()) {
    EXPECT_FALSE(kf.bow_features.empty()) << "keyframe " << id;
  }
}

// Localisation only with relocalisation switched off cannot place a frame, and says why.
TEST(MapIo, LocalizationOnlyHonoursRelocalizationEnabled) {
  AgentConfig config;
  config.tracking.relocalization.enabled = false;
  Agent agent = localising_in_first_map(config);
  const AgentUpdate first = agent.process(sequence().front());
  EXPECT_FALSE(first.has_pose());
  EXPECT_NE(first.reason.find("relocalisation disabled"), std::string::npos) << first.reason;
}

TEST(MapIo, LocalizationOnlyWithoutAMapTracksNothing) {
  AgentConfig config;
  config.localization_only = true;
  Agent agent(config, test::synthetic_rgbd_rig(), core::null_logger());
  for (int i = 0; i < 3; ++i) {
    const AgentUpdate u = agent.process(sequence()[static_cast<std::size_t>(i)]);
    EXPECT_EQ(u.status, FrameStatus::kNotInitialized);
    EXPECT_NE(u.reason.find("no map"), std::string::npos) << u.reason;
  }
  EXPECT_EQ(agent.map_stats().keyframes, 0u);
}

// A keyframe's pyramid must be the one its levels and scale factor make: a factor of 1 (or NaN) with 8
// levels loaded, and level predictions then divided by log(1).
TEST(MapIo, APyramidThatItsScaleFactorDoesNotMakeIsRefused) {
  const fs::path dir = test_dir();
  for (const double factor : {1.0, std::nan(""), 1.3}) {
    Map map = first_run().map;
    Keyframe* kf = map.keyframe(map.keyframes().begin()->first);
    ASSERT_NE(kf, nullptr);
    kf->frame.pyramid.scale_factor = factor;  // 1.3: finite and valid, but not what made the scales
    const fs::path file = dir / "pyramid.fsmap";
    save_map(map, file, 0);
    try {
      load_map(file);
      ADD_FAILURE() << "loaded a pyramid with scale factor " << factor;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("pyramid"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
  }
}

// A NaN or non-rigid keyframe pose, a NaN point or feature coordinate (a diverged solve, saved as it was)
// is refused on load, naming the file and what is wrong.
TEST(MapIo, NonFiniteOrNonRigidContentIsRefused) {
  const fs::path dir = test_dir();
  const std::vector<std::pair<std::string, std::function<void(Map&)>>> damages = {
      {"pose is not a finite rigid transform",
       [](Map& map) { map.keyframe(map.keyframes().rbegin()->first)->T_world_cam.translation().x() = std::nan(""); }},
      {"pose is not a finite rigid transform",
       [](Map& map) { map.keyframe(map.keyframes().rbegin()->first)->T_world_cam.linear() *= 1.01; }},
      {"coordinates or depth are not finite",
       [](Map& map) { map.keyframe(map.keyframes().begin()->first)->frame.depth_m[0] = std::nan(""); }},
      {"position, viewing direction or distance range not finite",
       [](Map& map) { map.point(map.point_ids().front())->position.y() = std::numeric_limits<double>::infinity(); }},
  };
  for (const auto& [why, damage] : damages) {
    SCOPED_TRACE(why);
    Map map = first_run().map;
    damage(map);
    const fs::path file = dir / "damaged.fsmap";
    save_map(map, file, 0);
    try {
      load_map(file);
      ADD_FAILURE() << "loaded";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
  }
}

// A map is written beside the file and renamed over it: a save that fails leaves the earlier map whole
// (the file was truncated first), and a save that works leaves no partial file.
TEST(MapIo, AFailedSaveLeavesTheEarlierMap) {
  const fs::path dir = test_dir();
  const fs::path file = dir / "kept.fsmap";
  save_map(first_run().map, file, 0);
  EXPECT_FALSE(fs::exists(dir / "kept.fsmap.partial"));
  const auto size = fs::file_size(file);
  // The partial file cannot be made (a folder of that name): the save fails, the map stays.
  fs::create_directories(dir / "kept.fsmap.partial" / "x");
  EXPECT_THROW(save_map(Map{}, file, 0), InputError);
  EXPECT_EQ(fs::file_size(file), size);
  EXPECT_NO_THROW(load_map(file));
  // Over a folder: refused, the folder untouched.
  fs::create_directories(dir / "folder.fsmap" / "y");
  EXPECT_THROW(save_map(first_run().map, dir / "folder.fsmap", 0), InputError);
  EXPECT_TRUE(fs::exists(dir / "folder.fsmap" / "y"));
  EXPECT_FALSE(fs::exists(dir / "folder.fsmap.partial"));
}

TEST(MapIo, TruncatedFilesAreInputErrorsNamingTheFile) {
  const std::string& bytes = first_run().bytes;
  const fs::path file = test_dir() / "truncated.fsmap";
  std::mt19937 rng(11);
  std::vector<std::size_t> sizes = {0, 1, 7, 8, 23, 24, 31, 32, 40, bytes.size() - 1, bytes.size() - 8};
  for (int i = 0; i < 40; ++i) sizes.push_back(std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng));
  for (std::size_t size : sizes) {
    const std::string why = load_error(file, bytes.substr(0, size));
    EXPECT_NE(why.find(file.string()), std::string::npos) << size << ": " << why;
    EXPECT_TRUE(why.find("truncated") != std::string::npos || why.find("magic") != std::string::npos)
        << size << ": " << why;
  }
  EXPECT_NE(load_error(file, bytes + "x").find("trailing bytes"), std::string::npos);
}

TEST(MapIo, FlippedBytesAreInputErrors) {
  const std::string& bytes = first_run().bytes;
  const fs::path file = test_dir() / "flipped.fsmap";
  std::mt19937 rng(5);
  std::uniform_int_distribution<std::size_t> position(0, bytes.size() - 1);
  for (int i = 0; i < 60; ++i) {
    std::string data = bytes;
    data[position(rng)] ^= static_cast<char>(1 << (i % 8));
    const std::string why = load_error(file, data);
    EXPECT_NE(why.find(file.string()), std::string::npos) << why;
  }
}

// With the checksum repaired a flip reaches the parser: the file either loads or is an InputError.
TEST(MapIo, FlippedBytesBehindARepairedChecksumNeverCrash) {
  const std::string& bytes = first_run().bytes;
  std::mt19937 rng(9);
  std::uniform_int_distribution<std::size_t> position(8, bytes.size() - 9);
  int rejected = 0;
  for (int i = 0; i < 150; ++i) {
    std::string data = bytes;
    const int flips = 1 + i % 4;
    for (int k = 0; k < flips; ++k) data[position(rng)] ^= static_cast<char>(0xFF);
    repair_checksum(data);
    try {
      const SavedMap loaded = map_from_bytes(data, "fuzzed.fsmap");
      EXPECT_LE(loaded.map.keyframe_count(), first_run().map.keyframe_count());
    } catch (const InputError& e) {
      ++rejected;
      EXPECT_EQ(std::string(e.what()).rfind("fuzzed.fsmap", 0), 0u) << e.what();
    }
  }
  std::printf("%d of 150 repaired-checksum mutations rejected\n", rejected);
  EXPECT_GT(rejected, 0);
}

TEST(MapIo, ForeignFilesAreInputErrors) {
  const fs::path dir = test_dir();
  std::vector<std::uint8_t> png;
  cv::imencode(".png", cv::Mat(16, 16, CV_8UC1, cv::Scalar(90)), png);
  const std::string why_png = load_error(dir / "image.png", std::string(png.begin(), png.end()));
  EXPECT_NE(why_png.find("image.png"), std::string::npos) << why_png;
  EXPECT_NE(why_png.find("not a fleetslam map file"), std::string::npos) << why_png;
  EXPECT_NE(load_error(dir / "text.txt", std::string(4096, 'a')).find("not a fleetslam map file"), std::string::npos);
  EXPECT_NE(load_error(dir / "empty.fsmap", "").find("truncated"), std::string::npos);
  // A vocabulary file is foreign too.
  EXPECT_THROW(load_map(default_vocabulary_path()), InputError);
  try {
    load_map(dir / "missing.fsmap");
    ADD_FAILURE() << "a missing file loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.fsmap"), std::string::npos);
  }
  EXPECT_THROW(load_map(dir), InputError);
}

TEST(MapIo, OtherFormatVersionsAreInputErrors) {
  std::string data = first_run().bytes;
  data[8] = 3;  // the u32 format version after the 8-byte magic
  repair_checksum(data);
  const fs::path file = test_dir() / "v3.fsmap";
  const std::string why = load_error(file, data);
  EXPECT_NE(why.find("version 3 is not supported"), std::string::npos) << why;
  EXPECT_NE(why.find(file.string()), std::string::npos) << why;
}

TEST(MapIo, AgentWithABadMapFileThrowsInputError) {
  const fs::path file = test_dir() / "bad.fsmap";
  write_bytes(file, first_run().bytes.substr(0, 1000));
  AgentConfig config;
  config.load_map = file.string();
  config.localization_only = true;
  EXPECT_THROW(Agent(config, test::synthetic_rgbd_rig(), core::null_logger()), InputError);
}

}  // namespace
}  // namespace fleetslam::slam
