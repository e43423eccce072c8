#pragma once
// Bag of binary words for ORB descriptors (place recognition, BoW matching): a vocabulary tree over
// 256-bit descriptors after Galvez-Lopez and Tardos, "Bags of Binary Words for Fast Place Recognition in
// Image Sequences" (IEEE T-RO 2012, the DBoW2 paper), written here from the paper: no bag-of-words library
// for binary descriptors is packaged for Debian (DESIGN.md), and DBoW2/DBoW3/FBoW would be vendored code.
//
//  - Tree: hierarchical k-medians (k-means with binary centres, each bit the majority of its cluster;
//    k-means++ seeding from a seeded std::mt19937, so training is deterministic). Branching factor k,
//    at most L levels below the root; the leaves are the words.
//  - Weights: TF-IDF. idf(w) = ln(N / n_w) over the N training images, n_w of which hold word w
//    (paper eq. 2). An image's vector holds tf(w) * idf(w), L1-normalised; words with idf 0 (present in
//    every training image) carry no information and are left out.
//  - Score: the L1 score s(a, b) = 1 - |a - b|_1 / 2 in [0, 1] (paper eq. 3); for L1-normalised vectors it
//    equals the sum over shared words of min(a_w, b_w), which is how it is computed.
//  - Direct index (FeatureVector): the features of an image grouped by their ancestor node `levels_up`
//    levels above the leaves (depth L - levels_up), so that matching only compares features sharing a node.
//
// Files: a versioned binary format of this project (load() / save(), see vocabulary_io.cpp), and the
// DBoW2 text format that ORB-SLAM's ORBvoc.txt uses (load_dbow2_text() / save_dbow2_text()).
// A Vocabulary is immutable once built: share it as shared_ptr<const Vocabulary>; its const methods may
// run on several threads at once.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"

namespace fleetslam::slam {

using WordId = std::uint32_t;
using NodeId = std::uint32_t;
inline constexpr NodeId kNoNode = std::numeric_limits<NodeId>::max();
inline constexpr WordId kNoWord = std::numeric_limits<WordId>::max();
inline constexpr int kDescriptorBytes = 32;  // 256-bit ORB (rBRIEF) descriptors

struct BowEntry {
  WordId word = 0;
  double weight = 0.0;
  bool operator==(const BowEntry& o) const { return word == o.word && weight == o.weight; }
};

// A sparse bag-of-words vector: entries in ascending word order, each word once, weights > 0 summing to
// 1 (L1-normalised) unless empty.
struct BowVector {
  std::vector<BowEntry> entries;

  bool empty() const { return entries.empty(); }
  std::size_t size() const { return entries.size(); }
  // The weight of a word, 0 when absent (binary search).
  double weight(WordId word) const;
  bool operator==(const BowVector& o) const { return entries == o.entries; }
};

// Features of one image grouped by a tree node (the direct index): ascending node order, each node's
// feature indices (rows of the descriptor matrix) ascending.
struct FeatureNode {
  NodeId node = 0;
  std::vector<int> features;
  bool operator==(const FeatureNode& o) const { return node == o.node && features == o.features; }
};
struct FeatureVector {
  std::vector<FeatureNode> nodes;

  bool empty() const { return nodes.empty(); }
  std::size_t size() const { return nodes.size(); }
  bool operator==(const FeatureVector& o) const { return nodes == o.nodes; }
};

// What transform() gives for one image.
struct BowTransform {
  BowVector bow;
  FeatureVector features;
  std::vector<WordId> words;  // per feature (descriptor row), its word
};

// The L1 score of two L1-normalised vectors: 1 - |a - b|_1 / 2, as the sum over shared words of
// min(a_w, b_w) in ascending word order (so KeyframeDatabase's scores are bit-identical), clamped to
// [0, 1]. Identical vectors score 1 (to rounding), vectors without a shared word 0.
double bow_score(const BowVector& a, const BowVector& b);

// The tree as plain arrays. Nodes in breadth-first order: node 0 is the root, parent[i] < i and parent
// is non-decreasing over i >= 1, so every node's children are contiguous and in order. Leaves, and only
// leaves, carry a word id; word ids are a permutation of 0 .. words-1.
struct VocabularyTree {
  int branching = 0;                      // k: at most this many children per node
  int depth_levels = 0;                   // L: leaves lie at most this many levels below the root
  std::vector<NodeId> parent;             // per node; kNoNode for the root
  std::vector<std::uint8_t> descriptors;  // kDescriptorBytes per node (the root's are zeros, unused)
  std::vector<WordId> word;               // per node: its word id for a leaf, kNoWord for an inner node
  std::vector<double> word_weight;        // per word: its IDF (finite, >= 0)
  std::uint64_t training_images = 0;      // N of the IDF; 0 when unknown (a DBoW2 text file)
  std::uint64_t training_descriptors = 0;  // 0 when unknown

  std::size_t nodes() const { return parent.size(); }
  std::size_t words() const { return word_weight.size(); }
  bool operator==(const VocabularyTree& o) const;
};

// Empty when `tree` is a valid vocabulary (the invariants above, at least one word, a root with
// children, at most k children per node, depth <= L, 1 <= k, 1 <= L), otherwise what is wrong.
std::string check_vocabulary_tree(const VocabularyTree& tree);

class Vocabulary {
 public:
  // An empty vocabulary: no words; transform() gives empty vectors.
  Vocabulary() = default;
  // Throws InputError("vocabulary", why) when check_vocabulary_tree finds the tree invalid.
  explicit Vocabulary(VocabularyTree tree);

  // This project's binary format (auto-detected) or a DBoW2 text vocabulary. Throws InputError naming the
  // file and what is wrong for unreadable, truncated, foreign or inconsistent files.
  static Vocabulary load(const std::filesystem::path& file);
  static Vocabulary load_binary(const std::filesystem::path& file);
  // DBoW2 text layout (ORB-SLAM's ORBvoc.txt): a line "k L scoring weighting", then one line per node
  // after the root, "parent is_leaf d0 .. d31 weight", descriptor bytes as decimal numbers; nodes are
  // numbered from 1 in file order, word ids given to leaves in file order. Only L1 scoring (0) and
  // TF-IDF weighting (0) are accepted: transform() implements those.
  static Vocabulary load_dbow2_text(const std::filesystem::path& file);
  // Throws InputError naming the file when it cannot be written.
  void save(const std::filesystem::path& file) const;
  void save_dbow2_text(const std::filesystem::path& file) const;

  // descriptors: N x 32 CV_8UC1 (any row stride), or empty. Every descriptor descends from the root to
  // the child of least Hamming distance (ties: the first child) until a leaf. FeatureVector nodes lie
  // `levels_up` levels above depth L (clamped at the root; a shallower leaf is its own group); every
  // feature is in it, those of zero-weight words too. Throws InputError for another matrix type or width.
  BowTransform transform(const cv::Mat& descriptors, int levels_up) const;
  // The BoW vector alone.
  BowVector bow(const cv::Mat& descriptors) const;
  // The word of one descriptor (kNoWord for an empty vocabulary).
  WordId word_of(const std::uint8_t* descriptor) const;
  static double score(const BowVector& a, const BowVector& b) { return bow_score(a, b); }

  bool empty() const { return tree_.words() == 0; }
  std::size_t words() const { return tree_.words(); }
  std::size_t nodes() const { return tree_.nodes(); }
  int branching() const { return tree_.branching; }
  int depth_levels() const { return tree_.depth_levels; }
  double word_weight(WordId word) const { return tree_.word_weight.at(word); }
  // The leaf node of a word, and a node's depth (root 0).
  NodeId word_node(WordId word) const { return word_node_.at(word); }
  int depth(NodeId node) const { return depth_.at(node); }
  const VocabularyTree& tree() const { return tree_; }

 private:
  // The leaf a descriptor descends to, and its ancestor at depth group_depth (or the leaf when shallower).
  NodeId descend(const std::uint8_t* descriptor, int group_depth, NodeId& group) const;

  VocabularyTree tree_;
  std::vector<NodeId> child_begin_;  // per node: children are [child_begin_, child_end_)
  std::vector<NodeId> child_end_;
  std::vector<int> depth_;
  std::vector<NodeId> word_node_;    // per word: its leaf
};

struct VocabularyConfig {
  int branching = 10;        // k
  int depth_levels = 5;      // L (k = 10, L = 5: up to 100k words, DBoW2's default; ORB-SLAM's is L = 6)
  int max_iterations = 20;   // k-medians iterations per node (fewer once no assignment changes)
  std::int64_t seed = 0;     // of the k-means++ seeding; the same seed and data give the same tree

  template <class V>
  void visit(V& v) {
    v("branching", branching, core::Limits<int>{2, 64});
    v("depth_levels", depth_levels, core::Limits<int>{1, 10});
    v("max_iterations", max_iterations, core::Limits<int>{1, 1000});
    v("seed", seed, core::Limits<std::int64_t>{0});
  }
};

// Trains a vocabulary from the descriptors of a set of training images (one N x 32 CV_8UC1 matrix per
// image). Nodes are split breadth first; each node's k-medians draws from its own generator seeded by
// (seed, node id). A node becomes a leaf at depth L or when its descriptors are all equal; a node with
// fewer distinct descriptors than k gets one child per distinct descriptor; clusters left empty by the
// iterations are dropped. N of the IDF counts the images with at least one descriptor.
class VocabularyTrainer {
 public:
  // Throws InputError for a config field out of its limits.
  explicit VocabularyTrainer(const VocabularyConfig& config, core::Logger logger = core::null_logger());
  // Throws InputError when a matrix is not N x 32 CV_8UC1 or there is no descriptor at all.
  Vocabulary train(const std::vector<cv::Mat>& descriptors_per_image) const;
  const VocabularyConfig& config() const { return config_; }

 private:
  VocabularyConfig config_;
  core::Logger logger_;
};

}  // namespace fleetslam::slam
