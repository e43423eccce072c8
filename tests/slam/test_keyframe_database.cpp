// KeyframeDatabase: queries find the right keyframe among many, agree with a brute-force oracle bit for
// bit, break ties by id, honour exclusions, limits and erasure.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <set>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/keyframe_database.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes random_descriptor(std::mt19937& rng) {
  Bytes d(kDescriptorBytes);
  for (auto& b : d) b = static_cast<std::uint8_t>(rng() & 0xFF);
  return d;
}

Bytes noisy(const Bytes& d, int bits, std::mt19937& rng) {
  Bytes out = d;
  for (int i = 0; i < bits; ++i) {
    const auto bit = rng() % (kDescriptorBytes * 8);
    out[bit / 8] = static_cast<std::uint8_t>(out[bit / 8] ^ (1u << (bit % 8)));
  }
  return out;
}

// A world of 200 "landmark" descriptors; place p sees 12 of them (a random choice per place).
struct Places {
  std::vector<Bytes> landmarks;
  std::vector<std::vector<int>> seen;

  explicit Places(int places, std::uint32_t seed) {
    std::mt19937 rng(seed);
    for (int i = 0; i < 200; ++i) landmarks.push_back(random_descriptor(rng));
    for (int p = 0; p < places; ++p) {
      std::vector<int> all(landmarks.size());
      for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
      std::shuffle(all.begin(), all.end(), rng);
      seen.emplace_back(all.begin(), all.begin() + 12);
    }
  }
  // An image of place p: 8 noisy samples of each landmark it sees.
  cv::Mat image(int p, std::mt19937& rng) const {
    cv::Mat m(12 * 8, kDescriptorBytes, CV_8UC1);
    int row = 0;
    for (int l : seen[static_cast<std::size_t>(p)]) {
      for (int s = 0; s < 8; ++s, ++row) {
        std::memcpy(m.ptr(row), noisy(landmarks[static_cast<std::size_t>(l)], 5, rng).data(), kDescriptorBytes);
      }
    }
    return m;
  }
};

class KeyframeDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(5);
    for (int p = 0; p < kPlaces; ++p) images_.push_back(places_.image(p, rng));
    VocabularyConfig config;
    config.branching = 6;
    config.depth_levels = 3;
    vocabulary_ = VocabularyTrainer(config).train(images_);
    // Keyframe ids 1000 + 3p, so that ids and places differ.
    for (int p = 0; p < kPlaces; ++p) database_.add(id_of(p), vocabulary_.bow(images_[static_cast<std::size_t>(p)]));
  }
  static KeyframeId id_of(int place) { return 1000 + 3 * place; }

  static constexpr int kPlaces = 80;
  Places places_{kPlaces, 17};
  std::vector<cv::Mat> images_;
  Vocabulary vocabulary_;
  KeyframeDatabase database_;
};

TEST_F(KeyframeDatabaseTest, QueryReturnsTheRightKeyframeAmongMany) {
  std::mt19937 rng(99);
  EXPECT_EQ(database_.size(), static_cast<std::size_t>(kPlaces));
  for (int p = 0; p < kPlaces; ++p) {
    const BowVector query = vocabulary_.bow(places_.image(p, rng));  // a new view of place p
    const std::vector<PlaceCandidate> found = database_.query(query, PlaceQuery{});
    ASSERT_FALSE(found.empty());
    EXPECT_EQ(found[0].id, id_of(p));
    EXPECT_GT(found[0].score, 0.5);
    if (found.size() > 1) {
      EXPECT_LT(found[1].score, 0.5 * found[0].score);
    }
  }
}

// Every keyframe's score by bow_score, sorted as the database sorts.
std::vector<PlaceCandidate> brute_force(const std::vector<std::pair<KeyframeId, BowVector>>& keyframes,
                                        const BowVector& query) {
  std::vector<PlaceCandidate> all;
  for (const auto& [id, bow] : keyframes) {
    int shared = 0;
    for (const BowEntry& e : query.entries) shared += bow.weight(e.word) > 0.0 ? 1 : 0;
    if (shared > 0) all.push_back({id, bow_score(query, bow), shared});
  }
  std::sort(all.begin(), all.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.score != b.score ? a.score > b.score : a.id < b.id;
  });
  return all;
}

TEST(KeyframeDatabase, AgreesWithBruteForceBitForBit) {
  // Random sparse vectors over 300 words, including exact duplicates (ties).
  std::mt19937 rng(3);
  std::vector<std::pair<KeyframeId, BowVector>> keyframes;
  KeyframeDatabase db;
  for (KeyframeId id = 0; id < 150; ++id) {
    BowVector bow;
    if (id % 10 == 9) {
      bow = keyframes[static_cast<std::size_t>(id - 5)].second;  // a duplicate of an earlier keyframe
    } else {
      std::set<WordId> words;
      while (words.size() < 20 + rng() % 30) words.insert(rng() % 300);
      double sum = 0.0;
      for (const WordId w : words) {
        bow.entries.push_back({w, 0.1 + static_cast<double>(rng() % 1000) / 1000.0});
        sum += bow.entries.back().weight;
      }
      for (BowEntry& e : bow.entries) e.weight /= sum;
    }
    keyframes.emplace_back(id * 7 % 151, bow);  // ids not in insertion order
    db.add(keyframes.back().first, bow);
  }
  for (std::size_t q = 0; q < keyframes.size(); q += 7) {
    const std::vector<PlaceCandidate> expected = brute_force(keyframes, keyframes[q].second);
    PlaceQuery all;
    all.max_results = 0;
    EXPECT_EQ(db.query(keyframes[q].second, all), expected);
    PlaceQuery top;
    top.max_results = 5;
    const std::vector<PlaceCandidate> best = db.query(keyframes[q].second, top);
    ASSERT_EQ(best.size(), 5u);
    EXPECT_TRUE(std::equal(best.begin(), best.end(), expected.begin()));
    EXPECT_NEAR(best[0].score, 1.0, 1e-12);  // the keyframe itself (or its duplicate, by id)
  }
}

TEST(KeyframeDatabase, EqualScoresAreOrderedById) {
  const BowVector bow{{{1, 0.25}, {4, 0.75}}};
  KeyframeDatabase db;
  for (const KeyframeId id : {42, 7, 19, 3}) db.add(id, bow);
  const std::vector<PlaceCandidate> found = db.query(bow);
  ASSERT_EQ(found.size(), 4u);
  EXPECT_EQ(found[0].id, 3);
  EXPECT_EQ(found[1].id, 7);
  EXPECT_EQ(found[2].id, 19);
  EXPECT_EQ(found[3].id, 42);
  for (const PlaceCandidate& c : found) {
    EXPECT_EQ(c.score, 1.0);
    EXPECT_EQ(c.shared_words, 2);
  }
}

TEST(KeyframeDatabase, ExcludeMinScoreSharedWordsAndLimit) {
  KeyframeDatabase db;
  db.add(1, BowVector{{{1, 0.5}, {2, 0.5}}});              // query score 1
  db.add(2, BowVector{{{1, 0.5}, {3, 0.5}}});              // 0.5, 1 shared word
  db.add(3, BowVector{{{2, 0.1}, {5, 0.9}}});              // 0.1
  db.add(4, BowVector{{{6, 1.0}}});                        // nothing shared
  const BowVector query{{{1, 0.5}, {2, 0.5}}};
  std::vector<PlaceCandidate> found = db.query(query);
  ASSERT_EQ(found.size(), 3u);
  EXPECT_EQ(found[0].id, 1);
  EXPECT_EQ(found[1].id, 2);
  EXPECT_EQ(found[2].id, 3);
  EXPECT_DOUBLE_EQ(found[1].score, 0.5);
  EXPECT_DOUBLE_EQ(found[2].score, 0.1);
  PlaceQuery q;
  q.exclude = {1};
  found = db.query(query, q);
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].id, 2);
  q.min_score = 0.2;
  found = db.query(query, q);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, 2);
  q = PlaceQuery{};
  q.min_shared_words = 2;
  found = db.query(query, q);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, 1);
  q = PlaceQuery{};
  q.max_results = 2;
  EXPECT_EQ(db.query(query, q).size(), 2u);
  EXPECT_TRUE(db.query(BowVector{}).empty());
  EXPECT_TRUE(db.query(BowVector{{{99, 1.0}}}).empty());
}

TEST(KeyframeDatabase, EraseAndReplace) {
  KeyframeDatabase db;
  db.add(1, BowVector{{{1, 0.5}, {2, 0.5}}});
  db.add(2, BowVector{{{2, 1.0}}});
  EXPECT_EQ(db.keyframes_with(2), (std::vector<KeyframeId>{1, 2}));
  EXPECT_TRUE(db.erase(1));
  EXPECT_FALSE(db.erase(1));
  EXPECT_FALSE(db.contains(1));
  EXPECT_EQ(db.find(1), nullptr);
  EXPECT_EQ(db.keyframes_with(2), (std::vector<KeyframeId>{2}));
  EXPECT_TRUE(db.keyframes_with(1).empty());
  std::vector<PlaceCandidate> found = db.query(BowVector{{{1, 0.5}, {2, 0.5}}});
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, 2);
  // Re-adding a keyframe replaces its vector (its slot is reused).
  db.add(5, BowVector{{{7, 1.0}}});
  db.add(5, BowVector{{{8, 1.0}}});
  EXPECT_EQ(db.size(), 2u);
  EXPECT_TRUE(db.keyframes_with(7).empty());
  EXPECT_EQ(db.keyframes_with(8), (std::vector<KeyframeId>{5}));
  ASSERT_NE(db.find(5), nullptr);
  EXPECT_EQ(*db.find(5), (BowVector{{{8, 1.0}}}));
  db.clear();
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.query(BowVector{{{8, 1.0}}}).empty());
}

TEST(KeyframeDatabase, RejectsVectorsVocabularyCannotMake) {
  KeyframeDatabase db;
  EXPECT_THROW(db.add(1, BowVector{{{3, 0.5}, {2, 0.5}}}), InvariantError);
  EXPECT_THROW(db.add(1, BowVector{{{2, 0.5}, {2, 0.5}}}), InvariantError);
  EXPECT_THROW(db.add(1, BowVector{{{2, 0.0}}}), InvariantError);
  EXPECT_EQ(db.size(), 0u);
}

}  // namespace
}  // namespace fleetslam::slam
