// Vocabulary: training recovers known clusters, TF-IDF vectors and L1 scores, the direct index,
// determinism, binary and DBoW2 text files (round trips, hand-written files, every kind of bad file).

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

Bytes random_descriptor(std::mt19937& rng) {
  Bytes d(kDescriptorBytes);
  for (auto& b : d) b = static_cast<std::uint8_t>(rng() & 0xFF);
  return d;
}

// `d` with `bits` distinct random bits flipped.
Bytes flipped(const Bytes& d, int bits, std::mt19937& rng) {
  Bytes out = d;
  std::vector<int> positions(kDescriptorBytes * 8);
  for (std::size_t i = 0; i < positions.size(); ++i) positions[i] = static_cast<int>(i);
  std::shuffle(positions.begin(), positions.end(), rng);
  for (int i = 0; i < bits; ++i) out[static_cast<std::size_t>(positions[static_cast<std::size_t>(i)] / 8)] ^=
      static_cast<std::uint8_t>(1u << (positions[static_cast<std::size_t>(i)] % 8));
  return out;
}

cv::Mat to_mat(const std::vector<Bytes>& rows) {
  cv::Mat m(static_cast<int>(rows.size()), kDescriptorBytes, CV_8UC1);
  for (int r = 0; r < m.rows; ++r) std::memcpy(m.ptr(r), rows[static_cast<std::size_t>(r)].data(), kDescriptorBytes);
  return m;
}

Bytes node_descriptor(const Vocabulary& v, NodeId node) {
  const auto* p = v.tree().descriptors.data() + std::size_t{node} * kDescriptorBytes;
  return Bytes(p, p + kDescriptorBytes);
}

// Images of a synthetic world: cluster centres; image i draws `per_cluster` noisy samples of each of its
// clusters.
struct Synthetic {
  std::vector<Bytes> centres;
  std::vector<std::vector<int>> image_clusters;
  std::vector<cv::Mat> images;
  std::vector<std::vector<int>> sample_cluster;  // per image, per row

  void make_images(int per_cluster, int noise_bits, std::mt19937& rng) {
    images.clear();
    sample_cluster.clear();
    for (const auto& clusters : image_clusters) {
      std::vector<Bytes> rows;
      std::vector<int> owner;
      for (int c : clusters) {
        for (int s = 0; s < per_cluster; ++s) {
          rows.push_back(flipped(centres[static_cast<std::size_t>(c)], noise_bits, rng));
          owner.push_back(c);
        }
      }
      images.push_back(to_mat(rows));
      sample_cluster.push_back(owner);
    }
  }
};

// `count` random centres; each image holds `per_image` of them (a sliding window, so each centre is in
// a few images only and has a positive IDF).
Synthetic flat_world(int count, int images, int per_image, std::uint32_t seed) {
  std::mt19937 rng(seed);
  Synthetic w;
  for (int c = 0; c < count; ++c) w.centres.push_back(random_descriptor(rng));
  for (int i = 0; i < images; ++i) {
    std::vector<int> clusters;
    for (int j = 0; j < per_image; ++j) clusters.push_back((i + j) % count);
    w.image_clusters.push_back(clusters);
  }
  w.make_images(12, 6, rng);
  return w;
}

Vocabulary train(const std::vector<cv::Mat>& images, int k, int levels, std::int64_t seed = 7) {
  VocabularyConfig config;
  config.branching = k;
  config.depth_levels = levels;
  config.seed = seed;
  return VocabularyTrainer(config).train(images);
}

std::set<Bytes> leaf_descriptors(const Vocabulary& v) {
  std::set<Bytes> leaves;
  for (WordId w = 0; w < v.words(); ++w) leaves.insert(node_descriptor(v, v.word_node(w)));
  return leaves;
}

TEST(VocabularyTraining, FlatClustersAreRecoveredExactly) {
  const Synthetic w = flat_world(8, 8, 3, 1);
  const Vocabulary v = train(w.images, 8, 1);
  ASSERT_EQ(v.words(), 8u);
  EXPECT_EQ(v.nodes(), 9u);
  // Each bit's majority over samples with 6 of 256 bits flipped is the centre's bit.
  EXPECT_EQ(leaf_descriptors(v), std::set<Bytes>(w.centres.begin(), w.centres.end()));
  // Every sample of a cluster reaches that cluster's word.
  std::map<int, WordId> word_of_cluster;
  for (std::size_t i = 0; i < w.images.size(); ++i) {
    for (int r = 0; r < w.images[i].rows; ++r) {
      const WordId word = v.word_of(w.images[i].ptr<std::uint8_t>(r));
      const int cluster = w.sample_cluster[i][static_cast<std::size_t>(r)];
      EXPECT_EQ(node_descriptor(v, v.word_node(word)), w.centres[static_cast<std::size_t>(cluster)]);
      const auto [it, inserted] = word_of_cluster.emplace(cluster, word);
      EXPECT_EQ(it->second, word);
    }
  }
  EXPECT_EQ(v.tree().training_images, 8u);
  EXPECT_EQ(v.tree().training_descriptors, 8u * 3u * 12u);
}

TEST(VocabularyTraining, HierarchicalClustersAreRecovered) {
  // 3 groups far apart (random centres), 3 clusters in each 20 bits from the group's centre.
  std::mt19937 rng(3);
  Synthetic w;
  std::vector<Bytes> groups;
  for (int g = 0; g < 3; ++g) groups.push_back(random_descriptor(rng));
  for (int g = 0; g < 3; ++g) {
    for (int c = 0; c < 3; ++c) w.centres.push_back(flipped(groups[static_cast<std::size_t>(g)], 20, rng));
  }
  for (int i = 0; i < 9; ++i) w.image_clusters.push_back({i, (i + 4) % 9});
  w.make_images(15, 3, rng);
  const Vocabulary v = train(w.images, 3, 2);
  ASSERT_EQ(v.words(), 9u);
  EXPECT_EQ(v.nodes(), 13u);
  EXPECT_EQ(leaf_descriptors(v), std::set<Bytes>(w.centres.begin(), w.centres.end()));
  // The clusters of one group share their level-1 node.
  for (WordId word = 0; word < v.words(); ++word) {
    const NodeId leaf = v.word_node(word);
    EXPECT_EQ(v.depth(leaf), 2);
    const auto centre = std::find(w.centres.begin(), w.centres.end(), node_descriptor(v, leaf));
    const auto group = (centre - w.centres.begin()) / 3;
    for (WordId other = 0; other < v.words(); ++other) {
      const auto c2 = std::find(w.centres.begin(), w.centres.end(), node_descriptor(v, v.word_node(other)));
      const bool same_group = (c2 - w.centres.begin()) / 3 == group;
      EXPECT_EQ(v.tree().parent[leaf] == v.tree().parent[v.word_node(other)], same_group);
    }
  }
}

TEST(VocabularyTraining, FewDistinctDescriptorsGiveOneLeafEach) {
  std::mt19937 rng(5);
  const Bytes a = random_descriptor(rng), b = random_descriptor(rng);
  // Node with 2 distinct descriptors (many copies) and k = 10: two children, leaves at depth 1.
  const Vocabulary v = train({to_mat({a, a, b, a}), to_mat({b, b})}, 10, 4);
  EXPECT_EQ(v.words(), 2u);
  EXPECT_EQ(v.nodes(), 3u);
  EXPECT_EQ(leaf_descriptors(v), (std::set<Bytes>{a, b}));
}

TEST(VocabularyTraining, IsDeterministic) {
  const Synthetic w = flat_world(40, 20, 6, 11);
  const Vocabulary a = train(w.images, 4, 3, 42);
  const Vocabulary b = train(w.images, 4, 3, 42);
  EXPECT_TRUE(a.tree() == b.tree());
  const BowTransform ta = a.transform(w.images[3], 1);
  const BowTransform tb = a.transform(w.images[3], 1);
  EXPECT_EQ(ta.bow, tb.bow);
  EXPECT_EQ(ta.features, tb.features);
  EXPECT_EQ(ta.words, tb.words);
}

TEST(VocabularyTraining, IdfFollowsImageCounts) {
  // Cluster 0 in every image, cluster c in image c only (N = 4 images).
  std::mt19937 rng(9);
  Synthetic w;
  for (int c = 0; c < 5; ++c) w.centres.push_back(random_descriptor(rng));
  w.image_clusters = {{0, 1}, {0, 2}, {0, 3}, {0, 4}};
  w.make_images(10, 4, rng);
  const Vocabulary v = train(w.images, 5, 1);
  ASSERT_EQ(v.words(), 5u);
  const WordId common = v.word_of(w.centres[0].data());
  EXPECT_EQ(v.word_weight(common), 0.0);
  for (int c = 1; c < 5; ++c) EXPECT_DOUBLE_EQ(v.word_weight(v.word_of(w.centres[static_cast<std::size_t>(c)].data())), std::log(4.0));
  // The word in every image carries no weight and is left out of the vectors.
  const BowVector bow = v.bow(w.images[0]);
  ASSERT_EQ(bow.size(), 1u);
  EXPECT_EQ(bow.entries[0].word, v.word_of(w.centres[1].data()));
  EXPECT_DOUBLE_EQ(bow.entries[0].weight, 1.0);
  EXPECT_EQ(bow.weight(common), 0.0);
}

TEST(VocabularyTraining, BadInputIsAnInputError) {
  VocabularyConfig config;
  config.branching = 1;
  EXPECT_THROW(VocabularyTrainer{config}, InputError);
  config = VocabularyConfig{};
  config.depth_levels = 0;
  EXPECT_THROW(VocabularyTrainer{config}, InputError);
  const VocabularyTrainer trainer(VocabularyConfig{});
  EXPECT_THROW(trainer.train({}), InputError);
  EXPECT_THROW(trainer.train({cv::Mat()}), InputError);
  EXPECT_THROW(trainer.train({cv::Mat(3, 16, CV_8UC1, cv::Scalar(1))}), InputError);
  EXPECT_THROW(trainer.train({cv::Mat(3, 32, CV_32FC1, cv::Scalar(1))}), InputError);
}

class VocabularyScoring : public ::testing::Test {
 protected:
  void SetUp() override {
    world_ = flat_world(60, 30, 8, 21);
    vocabulary_ = train(world_.images, 4, 3);
  }
  Synthetic world_;
  Vocabulary vocabulary_;
};

TEST_F(VocabularyScoring, VectorsAreSortedAndL1Normalised) {
  for (const cv::Mat& image : world_.images) {
    const BowVector bow = vocabulary_.bow(image);
    ASSERT_FALSE(bow.empty());
    double sum = 0.0;
    for (std::size_t i = 0; i < bow.size(); ++i) {
      EXPECT_GT(bow.entries[i].weight, 0.0);
      if (i > 0) {
        EXPECT_LT(bow.entries[i - 1].word, bow.entries[i].word);
      }
      sum += bow.entries[i].weight;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_EQ(vocabulary_.transform(image, 1).bow, bow);
  }
}

TEST_F(VocabularyScoring, IdenticalImagesScoreOneAndHighest) {
  std::mt19937 rng(77);
  for (std::size_t i = 0; i < world_.images.size(); i += 5) {
    const BowVector bow = vocabulary_.bow(world_.images[i]);
    EXPECT_NEAR(Vocabulary::score(bow, bow), 1.0, 1e-12);
    // The same scene sampled again (new noise) scores highest of all images.
    Synthetic again = world_;
    again.image_clusters = {world_.image_clusters[i]};
    again.make_images(12, 6, rng);
    const BowVector query = vocabulary_.bow(again.images[0]);
    double best = -1.0;
    std::size_t best_image = 0;
    for (std::size_t j = 0; j < world_.images.size(); ++j) {
      const double s = Vocabulary::score(query, vocabulary_.bow(world_.images[j]));
      if (s > best) {
        best = s;
        best_image = j;
      }
    }
    EXPECT_EQ(best_image, i);
    EXPECT_GT(best, 0.8);
  }
}

TEST_F(VocabularyScoring, DifferentScenesScoreLow) {
  // Images 0 and 15 share no cluster (8 consecutive of 60 each).
  const BowVector a = vocabulary_.bow(world_.images[0]);
  const BowVector b = vocabulary_.bow(world_.images[15]);
  EXPECT_LT(Vocabulary::score(a, b), 0.05);
  // Half the clusters shared (images 0 and 4): in between.
  const double half = Vocabulary::score(a, vocabulary_.bow(world_.images[4]));
  EXPECT_GT(half, 0.3);
  EXPECT_LT(half, 0.7);
  EXPECT_EQ(Vocabulary::score(a, BowVector{}), 0.0);
}

TEST_F(VocabularyScoring, ScoreIsOneMinusHalfL1Distance) {
  for (std::size_t i = 0; i + 3 < world_.images.size(); i += 3) {
    const BowVector a = vocabulary_.bow(world_.images[i]);
    const BowVector b = vocabulary_.bow(world_.images[i + 3]);
    std::map<WordId, double> diff;
    for (const BowEntry& e : a.entries) diff[e.word] += e.weight;
    for (const BowEntry& e : b.entries) diff[e.word] -= e.weight;
    double l1 = 0.0;
    for (const auto& [word, d] : diff) l1 += std::abs(d);
    EXPECT_NEAR(Vocabulary::score(a, b), 1.0 - 0.5 * l1, 1e-12);
    EXPECT_EQ(Vocabulary::score(a, b), Vocabulary::score(b, a));
  }
}

TEST_F(VocabularyScoring, DirectIndexGroupsFeaturesByAncestor) {
  const cv::Mat& image = world_.images[2];
  for (int levels_up = 0; levels_up <= 4; ++levels_up) {
    const BowTransform t = vocabulary_.transform(image, levels_up);
    std::vector<int> all;
    for (std::size_t n = 0; n < t.features.size(); ++n) {
      const FeatureNode& group = t.features.nodes[n];
      if (n > 0) {
        EXPECT_LT(t.features.nodes[n - 1].node, group.node);
      }
      EXPECT_TRUE(std::is_sorted(group.features.begin(), group.features.end()));
      for (int f : group.features) {
        all.push_back(f);
        // The group node is the word's ancestor at depth L - levels_up (or the leaf when shallower).
        NodeId node = vocabulary_.word_node(t.words[static_cast<std::size_t>(f)]);
        const int target = std::max(0, vocabulary_.depth_levels() - levels_up);
        while (vocabulary_.depth(node) > target) node = vocabulary_.tree().parent[node];
        EXPECT_EQ(node, group.node);
      }
    }
    std::sort(all.begin(), all.end());
    ASSERT_EQ(all.size(), static_cast<std::size_t>(image.rows));
    for (int i = 0; i < image.rows; ++i) EXPECT_EQ(all[static_cast<std::size_t>(i)], i);
    if (levels_up >= vocabulary_.depth_levels()) {
      ASSERT_EQ(t.features.size(), 1u);
      EXPECT_EQ(t.features.nodes[0].node, 0u);
    }
  }
}

TEST_F(VocabularyScoring, TransformRejectsOtherMatricesAndAcceptsEmptyOnes) {
  EXPECT_THROW(vocabulary_.transform(cv::Mat(4, 16, CV_8UC1, cv::Scalar(0)), 1), InputError);
  EXPECT_THROW(vocabulary_.bow(cv::Mat(4, 32, CV_8UC3, cv::Scalar(0))), InputError);
  const BowTransform t = vocabulary_.transform(cv::Mat(), 1);
  EXPECT_TRUE(t.bow.empty());
  EXPECT_TRUE(t.features.empty());
  // A row view with a stride (rows of a wider matrix) works as a copy does.
  cv::Mat wide(world_.images[1].rows, 64, CV_8UC1, cv::Scalar(0));
  world_.images[1].copyTo(wide.colRange(16, 48));
  EXPECT_EQ(vocabulary_.bow(wide.colRange(16, 48)), vocabulary_.bow(world_.images[1]));
  // An empty vocabulary gives empty vectors.
  const Vocabulary none;
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(none.bow(world_.images[0]).empty());
  EXPECT_EQ(none.word_of(world_.images[0].ptr<std::uint8_t>(0)), kNoWord);
}

// ---- files ----

class VocabularyFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("fleetslam_vocabulary_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    world_ = flat_world(40, 20, 6, 31);
    vocabulary_ = train(world_.images, 3, 3);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  static void write(const fs::path& p, const std::string& data) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
  }
  // InputError whose message names the file and contains `why`.
  template <class Load>
  static void expect_input_error(Load load, const fs::path& file, const std::string& why) {
    try {
      load(file);
      ADD_FAILURE() << "no error for " << file;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  }
  static std::uint64_t fnv1a(const std::string& s, std::size_t size) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (std::size_t i = 0; i < size; ++i) {
      h ^= static_cast<unsigned char>(s[i]);
      h *= 0x100000001b3ULL;
    }
    return h;
  }
  static void reseal(std::string& data) {
    const std::uint64_t h = fnv1a(data, data.size() - 8);
    for (int i = 0; i < 8; ++i) data[data.size() - 8 + static_cast<std::size_t>(i)] = static_cast<char>((h >> (8 * i)) & 0xFF);
  }

  fs::path dir_;
  Synthetic world_;
  Vocabulary vocabulary_;
};

TEST_F(VocabularyFiles, BinaryRoundTripIsExact) {
  const fs::path file = dir_ / "v.fsvoc";
  vocabulary_.save(file);
  const Vocabulary loaded = Vocabulary::load_binary(file);
  EXPECT_TRUE(loaded.tree() == vocabulary_.tree());
  EXPECT_TRUE(Vocabulary::load(file).tree() == vocabulary_.tree());
  for (const cv::Mat& image : world_.images) {
    const BowTransform a = vocabulary_.transform(image, 2);
    const BowTransform b = loaded.transform(image, 2);
    EXPECT_EQ(a.bow, b.bow);
    EXPECT_EQ(a.features, b.features);
  }
  // Saving the loaded vocabulary gives the same bytes.
  loaded.save(dir_ / "again.fsvoc");
  EXPECT_EQ(read(file), read(dir_ / "again.fsvoc"));
}

TEST_F(VocabularyFiles, Dbow2TextRoundTripIsExact) {
  const fs::path file = dir_ / "v.txt";
  vocabulary_.save_dbow2_text(file);
  const Vocabulary loaded = Vocabulary::load_dbow2_text(file);
  VocabularyTree expected = vocabulary_.tree();
  expected.training_images = 0;  // the text format does not keep them
  expected.training_descriptors = 0;
  EXPECT_TRUE(loaded.tree() == expected);
  EXPECT_TRUE(Vocabulary::load(file).tree() == expected);
  EXPECT_EQ(loaded.bow(world_.images[5]), vocabulary_.bow(world_.images[5]));
}

// A small DBoW2 file in depth-first order (a node's children together, then their subtrees), which the
// loader turns breadth first; word ids follow the leaves' file order, as in DBoW2.
constexpr const char* kSmallDbow2 =
    "2 2  0 0\n"
    "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n"             // 1: inner, zeros
    "1 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0.5\n"           // 2: word 0
    "1 1 15 15 15 15 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1.25\n"      // 3: word 1
    "0 1 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 255 "
    "255 255 255 255 255 255 255 255 2 \r\n"                                               // 4: word 2 (CRLF, space)
    "\n";

TEST_F(VocabularyFiles, HandWrittenDbow2TextLoads) {
  const fs::path file = dir_ / "small.txt";
  write(file, kSmallDbow2);
  const Vocabulary v = Vocabulary::load_dbow2_text(file);
  EXPECT_EQ(v.branching(), 2);
  EXPECT_EQ(v.depth_levels(), 2);
  EXPECT_EQ(v.nodes(), 5u);
  ASSERT_EQ(v.words(), 3u);
  EXPECT_EQ(v.word_weight(0), 0.5);
  EXPECT_EQ(v.word_weight(1), 1.25);
  EXPECT_EQ(v.word_weight(2), 2.0);
  EXPECT_EQ(v.tree().training_images, 0u);
  Bytes zeros(kDescriptorBytes, 0), ones(kDescriptorBytes, 0xFF), near_word1(kDescriptorBytes, 0);
  near_word1[0] = 0x0F;
  near_word1[1] = 0x0F;
  near_word1[2] = 0x0F;
  EXPECT_EQ(v.word_of(zeros.data()), 0u);
  EXPECT_EQ(v.word_of(near_word1.data()), 1u);
  EXPECT_EQ(v.word_of(ones.data()), 2u);
  // Word 2 is a leaf at depth 1; the tree is breadth first now (root's children first).
  EXPECT_EQ(v.depth(v.word_node(2)), 1);
  EXPECT_EQ(v.tree().parent, (std::vector<NodeId>{kNoNode, 0, 0, 1, 1}));
  EXPECT_EQ(v.tree().word, (std::vector<WordId>{kNoWord, kNoWord, 2, 0, 1}));
  // tf-idf: 2 features of word 0 (idf 0.5) and 1 of word 2 (idf 2): 1 : 2 -> 1/3, 2/3.
  const BowVector bow = v.bow(to_mat({zeros, zeros, ones}));
  ASSERT_EQ(bow.size(), 2u);
  EXPECT_DOUBLE_EQ(bow.weight(0), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(bow.weight(2), 2.0 / 3.0);
  // load() detects the text format.
  EXPECT_TRUE(Vocabulary::load(file).tree() == v.tree());
}

TEST_F(VocabularyFiles, BadBinaryFilesAreInputErrors) {
  const fs::path good = dir_ / "good.fsvoc";
  vocabulary_.save(good);
  const std::string data = read(good);
  const fs::path bad = dir_ / "bad.fsvoc";
  const auto load_binary = [](const fs::path& f) { return Vocabulary::load_binary(f); };
  const auto load = [](const fs::path& f) { return Vocabulary::load(f); };

  expect_input_error(load_binary, dir_ / "absent.fsvoc", "cannot open");
  for (const std::size_t size : {std::size_t{0}, std::size_t{7}, std::size_t{40}, std::size_t{100}, data.size() / 2,
                                 data.size() - 1}) {
    write(bad, data.substr(0, size));
    expect_input_error(load_binary, bad, "truncated");
  }
  write(bad, data + "x");
  expect_input_error(load_binary, bad, "trailing bytes");
  std::string wrong = data;
  wrong[0] = 'X';
  write(bad, wrong);
  expect_input_error(load_binary, bad, "bad magic");
  expect_input_error(load, bad, "bad magic");
  wrong = data;
  wrong[8] = 2;  // version 2
  write(bad, wrong);
  expect_input_error(load_binary, bad, "version 2");
  wrong = data;
  wrong[12] = 64;  // 64-byte descriptors
  write(bad, wrong);
  expect_input_error(load_binary, bad, "64 bytes");
  wrong = data;
  wrong[24] = static_cast<char>(0xFF);  // node count no longer matches the file's size
  write(bad, wrong);
  expect_input_error(load_binary, bad, "bytes");
  wrong = data;
  wrong[data.size() / 2] = static_cast<char>(wrong[data.size() / 2] ^ 0x10);
  write(bad, wrong);
  expect_input_error(load_binary, bad, "checksum");
  // A consistent checksum over an inconsistent tree: node 2's parent made a later node.
  wrong = data;
  wrong[56 + 2 * 4] = 5;
  reseal(wrong);
  write(bad, wrong);
  expect_input_error(load_binary, bad, "inconsistent vocabulary tree");
  // A leaf without a word.
  wrong = data;
  const std::size_t n = vocabulary_.nodes();
  const std::size_t words_at = 56 + n * 4 + n * 32;
  const std::size_t leaf = vocabulary_.word_node(0);
  for (int i = 0; i < 4; ++i) wrong[words_at + leaf * 4 + static_cast<std::size_t>(i)] = static_cast<char>(0xFF);
  reseal(wrong);
  write(bad, wrong);
  expect_input_error(load_binary, bad, "leaf without a word");
  // A foreign file: load() names neither format.
  write(bad, std::string("\x89PNG\r\n\x1a\n", 8) + std::string(200, '\x01'));
  expect_input_error(load, bad, "neither");
  // A folder.
  expect_input_error(load, dir_, dir_.string());
}

TEST_F(VocabularyFiles, EveryByteFlipOrTruncationIsCaught) {
  const fs::path good = dir_ / "good.fsvoc";
  vocabulary_.save(good);
  const std::string data = read(good);
  const fs::path bad = dir_ / "bad.fsvoc";
  std::mt19937 rng(1);
  for (int trial = 0; trial < 200; ++trial) {
    std::string wrong = data;
    const std::size_t at = rng() % data.size();
    wrong[at] = static_cast<char>(wrong[at] ^ static_cast<char>(1 + rng() % 255));
    if (trial % 2 == 1) wrong.resize(rng() % data.size());
    write(bad, wrong);
    EXPECT_THROW(Vocabulary::load(bad), InputError) << "byte " << at;
  }
}

TEST_F(VocabularyFiles, BadTextFilesAreInputErrorsNamingTheLine) {
  const fs::path bad = dir_ / "bad.txt";
  const auto load_text = [](const fs::path& f) { return Vocabulary::load_dbow2_text(f); };
  const std::string zeros32 = " 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0";
  const std::string leaf = "0 1" + zeros32 + " 1\n";
  struct Case {
    std::string text;
    std::string why;
  };
  const std::vector<Case> cases = {
      {"", "empty file"},
      {"2 2 0 0\n", "no vocabulary nodes"},
      {"2 2 0\n" + leaf, ":1: expected a DBoW2 header"},
      {"two 2 0 0\n" + leaf, ":1: k 'two' is not an integer"},
      {"0 2 0 0\n" + leaf, ":1: k = 0"},
      {"2 99 0 0\n" + leaf, ":1: L = 99"},
      {"2 2 3 0\n" + leaf, ":1: scoring 3 is not supported"},
      {"2 2 0 1\n" + leaf, ":1: weighting 1 is not supported"},
      {"2 2 0 0\n0 1" + zeros32 + "\n", ":2: expected 'parent is_leaf"},
      {"2 2 0 0\n0 1" + zeros32 + " x\n", ":2: weight 'x' is not a finite number"},
      {"2 2 0 0\n0 1" + zeros32 + " nan\n", ":2: weight 'nan'"},
      {"2 2 0 0\n0 1" + zeros32 + " -1\n", ":2: negative weight"},
      {"2 2 0 0\n0 1 7a" + zeros32.substr(2) + " 1\n", ":2: descriptor byte '7a'"},
      {"2 2 0 0\n0 1 256" + zeros32.substr(2) + " 1\n", ":2: descriptor byte 256"},
      {"2 2 0 0\n0 2" + zeros32 + " 1\n", ":2: is_leaf must be 0 or 1"},
      {"2 2 0 0\n" + leaf + "5 1" + zeros32 + " 1\n", ":3: parent 5 of node 2 is not an earlier node"},
      {"2 2 0 0\n" + leaf + "-1 1" + zeros32 + " 1\n", ":3: parent -1"},
      {"2 2 0 0\n" + leaf + "1 1" + zeros32 + " 1\n", ":3: parent 1 is marked as a leaf"},
      {"2 2 0 0\n" + leaf + leaf + leaf, ":4: node 0 gets more than k = 2 children"},
      {"2 1 0 0\n0 0" + zeros32 + " 0\n1 1" + zeros32 + " 1\n", ":3: node 2 lies deeper than L = 1"},
      {"2 2 0 0\n" + leaf + "0 0" + zeros32 + " 0\n", ":3: node 2 is not a leaf but has no children"},
      {"2 2 0 0\n" + leaf + std::string("0 1\0 0", 6) + "\n", "binary data"},
  };
  for (const Case& c : cases) {
    write(bad, c.text);
    SCOPED_TRACE(c.why);
    expect_input_error(load_text, bad, c.why);
  }
}

TEST_F(VocabularyFiles, CorruptedTextNeverCrashes) {
  const fs::path good = dir_ / "good.txt";
  vocabulary_.save_dbow2_text(good);
  const std::string data = read(good);
  const fs::path bad = dir_ / "bad.txt";
  std::mt19937 rng(2);
  const std::string replacements = "0123456789 -.\nxe";
  for (int trial = 0; trial < 200; ++trial) {
    std::string wrong = data;
    const std::size_t at = rng() % data.size();
    wrong[at] = replacements[rng() % replacements.size()];
    if (trial % 3 == 2) wrong.resize(rng() % data.size());
    write(bad, wrong);
    try {
      const Vocabulary v = Vocabulary::load(bad);
      EXPECT_TRUE(check_vocabulary_tree(v.tree()).empty());
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos);
    }
  }
}

TEST(VocabularyTree, ChecksFindBrokenTrees) {
  VocabularyTree t;
  t.branching = 2;
  t.depth_levels = 2;
  t.parent = {kNoNode, 0, 0};
  t.descriptors.assign(3 * kDescriptorBytes, 0);
  t.word = {kNoWord, 0, 1};
  t.word_weight = {1.0, 1.0};
  EXPECT_EQ(check_vocabulary_tree(t), "");
  EXPECT_NO_THROW(Vocabulary{t});
  auto broken = [&](auto change) {
    VocabularyTree b = t;
    change(b);
    return check_vocabulary_tree(b);
  };
  EXPECT_NE(broken([](VocabularyTree& b) { b.word = {kNoWord, 0, 0}; }).find("two leaves"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) { b.word = {0, 1, kNoWord}; }).find("inner node"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) { b.word_weight = {1.0}; }).find("out of range"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) { b.word_weight[1] = -1.0; }).find("weight"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) { b.branching = 1; }).find("more than k"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) { b.parent[2] = 2; }).find("not an earlier node"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) { b.descriptors.pop_back(); }).find("descriptor"), std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) {
              b.parent = {kNoNode, 0, 1, 0};
              b.descriptors.resize(4 * kDescriptorBytes);
              b.word = {kNoWord, kNoWord, 0, 1};
            }).find("breadth-first"),
            std::string::npos);
  EXPECT_NE(broken([](VocabularyTree& b) {
              b.depth_levels = 1;
              b.parent = {kNoNode, 0, 1};
              b.word = {kNoWord, kNoWord, 0};
              b.word_weight = {1.0};
            }).find("deeper than L"),
            std::string::npos);
  VocabularyTree root_only = t;
  root_only.parent = {kNoNode};
  root_only.descriptors.resize(kDescriptorBytes);
  root_only.word = {0};
  root_only.word_weight = {1.0};
  EXPECT_NE(check_vocabulary_tree(root_only), "");
  EXPECT_THROW(Vocabulary{root_only}, InputError);
}

}  // namespace
}  // namespace fleetslam::slam
