// The shipped vocabulary on the real sequences: frames close in time score higher than frames far apart,
// and a keyframe database of every 10th frame answers each other frame with a keyframe close in time.

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/keyframe_database.hpp"
#include "fleetslam/slam/orb_extractor.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {
namespace {

namespace fs = std::filesystem;

const fs::path kData = FLEETSLAM_DATA_DIR;
const fs::path kVocabulary = fs::path(FLEETSLAM_SOURCE_DIR) / "data" / "vocabulary" / "orb_default.fsvoc";

#define SKIP_WITHOUT(folder)                                                                                   \
  if (!fs::is_directory(folder)) {                                                                             \
    GTEST_SKIP() << "real data not found at " << (folder) << " (set FLEETSLAM_DATA_DIR to the shared data)"; \
  }

// BoW vectors of a sequence's cam0 frames (every frame).
std::vector<BowVector> sequence_bows(const fs::path& root, const Vocabulary& vocabulary) {
  core::DatasetConfig config;
  config.load_imu = false;
  config.stereo = false;
  auto source = core::open_dataset(root, std::nullopt, config, core::null_logger());
  const OrbExtractor extractor(OrbExtractorConfig{});
  std::vector<BowVector> bows;
  while (auto frame = source->next()) bows.push_back(vocabulary.bow(extractor.extract(frame->image).descriptors));
  return bows;
}

struct Separation {
  double near_mean = 0.0;
  double far_mean = 0.0;
  int references = 0;
  int references_near_wins = 0;  // references whose mean near score exceeds their best far score
};

// Scores of frame pairs 1..near_max frames apart against pairs >= far_min frames apart.
Separation separation(const std::vector<BowVector>& bows, int near_max, int far_min) {
  Separation s;
  double near_sum = 0.0, far_sum = 0.0;
  int near_count = 0, far_count = 0;
  const int n = static_cast<int>(bows.size());
  for (int r = 0; r < n; r += 5) {
    double ref_near = 0.0, ref_far_best = 0.0;
    int ref_near_count = 0;
    for (int i = 0; i < n; ++i) {
      const int gap = std::abs(i - r);
      if (gap == 0 || (gap > near_max && gap < far_min)) continue;
      const double score = bow_score(bows[static_cast<std::size_t>(r)], bows[static_cast<std::size_t>(i)]);
      if (gap <= near_max) {
        near_sum += score;
        ++near_count;
        ref_near += score;
        ++ref_near_count;
      } else {
        far_sum += score;
        ++far_count;
        ref_far_best = std::max(ref_far_best, score);
      }
    }
    if (ref_near_count == 0) continue;
    ++s.references;
    if (ref_near / ref_near_count > ref_far_best) ++s.references_near_wins;
  }
  s.near_mean = near_sum / std::max(near_count, 1);
  s.far_mean = far_sum / std::max(far_count, 1);
  return s;
}

// Every 10th frame a keyframe; the other frames query the database: share of frames whose best candidate
// is one of the two keyframes around them.
double database_hit_rate(const std::vector<BowVector>& bows) {
  KeyframeDatabase db;
  for (std::size_t i = 0; i < bows.size(); i += 10) db.add(static_cast<KeyframeId>(i), bows[i]);
  int queries = 0, hits = 0;
  for (std::size_t i = 0; i < bows.size(); ++i) {
    if (i % 10 == 0) continue;
    PlaceQuery q;
    q.max_results = 1;
    const std::vector<PlaceCandidate> best = db.query(bows[i], q);
    ++queries;
    if (!best.empty() && std::abs(best[0].id - static_cast<KeyframeId>(i)) < 10) ++hits;
  }
  return static_cast<double>(hits) / std::max(queries, 1);
}

// The shipped vocabulary, loaded once for the suite.
class RealVocabulary : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (fs::exists(kVocabulary)) shipped() = std::make_unique<const Vocabulary>(Vocabulary::load(kVocabulary));
  }
  static void TearDownTestSuite() { shipped().reset(); }
  void SetUp() override {
    ASSERT_NE(shipped(), nullptr) << "the shipped vocabulary " << kVocabulary << " is missing";
    vocabulary_ = shipped().get();
  }
  static std::unique_ptr<const Vocabulary>& shipped() {
    static std::unique_ptr<const Vocabulary> vocabulary;
    return vocabulary;
  }
  const Vocabulary* vocabulary_ = nullptr;
};

TEST_F(RealVocabulary, ShippedVocabularyIsTheDocumentedOne) {
  EXPECT_EQ(vocabulary_->branching(), 10);
  EXPECT_EQ(vocabulary_->depth_levels(), 4);
  EXPECT_GT(vocabulary_->words(), 5000u);
  EXPECT_EQ(vocabulary_->tree().training_images, 295u);
  EXPECT_LT(fs::file_size(kVocabulary), 5u * 1024u * 1024u);
}

TEST_F(RealVocabulary, TumFramesCloseInTimeScoreHigher) {
  const fs::path tum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
  SKIP_WITHOUT(tum);
  const std::vector<BowVector> bows = sequence_bows(tum, *vocabulary_);
  ASSERT_EQ(bows.size(), 200u);
  // 30 Hz: near = within 0.1 s, far = 2 s or more apart (the camera has turned away).
  const Separation s = separation(bows, 3, 60);
  const double hit_rate = database_hit_rate(bows);
  std::cout << "TUM fr1_rpy: near mean " << s.near_mean << ", far mean " << s.far_mean << ", near beats best far in "
            << s.references_near_wins << "/" << s.references << " references; database hit rate " << hit_rate << "\n";
  // Measured with the shipped vocabulary: near 0.29, far 0.13, 38/40, hit rate 0.79 (chance: 0.1).
  EXPECT_GT(s.near_mean, 1.8 * s.far_mean);
  EXPECT_GE(s.references_near_wins, s.references * 85 / 100);
  EXPECT_GE(hit_rate, 0.7);
}

TEST_F(RealVocabulary, EurocFramesCloseInTimeScoreHigher) {
  const fs::path euroc = kData / "euroc" / "V1_01_easy_micro";
  SKIP_WITHOUT(euroc);
  const std::vector<BowVector> bows = sequence_bows(euroc, *vocabulary_);
  ASSERT_EQ(bows.size(), 95u);
  // 20 Hz: near = within 0.1 s, far = 2 s or more apart.
  const Separation s = separation(bows, 2, 40);
  const double hit_rate = database_hit_rate(bows);
  std::cout << "EuRoC V1_01: near mean " << s.near_mean << ", far mean " << s.far_mean << ", near beats best far in "
            << s.references_near_wins << "/" << s.references << " references; database hit rate " << hit_rate << "\n";
  // Measured: near 0.47, far 0.28 (the micro excerpt is 4.7 s of one room), 17/19, hit rate 0.85 (chance 0.2).
  EXPECT_GT(s.near_mean, 1.4 * s.far_mean);
  EXPECT_GE(s.references_near_wins, s.references * 80 / 100);
  EXPECT_GE(hit_rate, 0.7);
}

}  // namespace
}  // namespace fleetslam::slam
