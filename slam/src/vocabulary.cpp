// Vocabulary tree: structure checks, descriptor -> word descent, TF-IDF BoW vectors, direct index, L1 score.

#include "fleetslam/slam/vocabulary.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::slam {

double BowVector::weight(WordId word) const {
  const auto it = std::lower_bound(entries.begin(), entries.end(), word,
                                   [](const BowEntry& e, WordId w) { return e.word < w; });
  return it != entries.end() && it->word == word ? it->weight : 0.0;
}

double bow_score(const BowVector& a, const BowVector& b) {
  // 1 - |a - b|_1 / 2 = sum over shared words of min(a_w, b_w) when both sum to 1 (DBoW2 paper, eq. 3).
  double score = 0.0;
  auto ia = a.entries.begin();
  auto ib = b.entries.begin();
  while (ia != a.entries.end() && ib != b.entries.end()) {
    if (ia->word < ib->word) {
      ++ia;
    } else if (ib->word < ia->word) {
      ++ib;
    } else {
      score += std::min(ia->weight, ib->weight);
      ++ia;
      ++ib;
    }
  }
  return std::clamp(score, 0.0, 1.0);
}

bool VocabularyTree::operator==(const VocabularyTree& o) const {
  return branching == o.branching && depth_levels == o.depth_levels && parent == o.parent &&
         descriptors == o.descriptors && word == o.word && word_weight == o.word_weight &&
         training_images == o.training_images && training_descriptors == o.training_descriptors;
}

namespace {

std::string node_text(std::size_t node) { return "node " + std::to_string(node); }

// Parent links: breadth-first order; fills each node's child count and depth.
std::string check_parents(const VocabularyTree& tree, std::vector<std::size_t>& children, std::vector<int>& depth) {
  const std::size_t n = tree.nodes();
  children.assign(n, 0);
  depth.assign(n, 0);
  if (tree.parent[0] != kNoNode) return "the root (node 0) has a parent";
  for (std::size_t i = 1; i < n; ++i) {
    const NodeId p = tree.parent[i];
    if (p == kNoNode || p >= i) {
      return node_text(i) + ": parent " + (p == kNoNode ? std::string("none") : std::to_string(p)) +
             " is not an earlier node";
    }
    if (i > 1 && p < tree.parent[i - 1]) {
      return node_text(i) + ": not in breadth-first order (parent " + std::to_string(p) + " after " +
             std::to_string(tree.parent[i - 1]) + ")";
    }
    if (++children[p] > static_cast<std::size_t>(tree.branching)) {
      return node_text(p) + ": more than k = " + std::to_string(tree.branching) + " children";
    }
    depth[i] = depth[p] + 1;
    if (depth[i] > tree.depth_levels) {
      return node_text(i) + ": deeper than L = " + std::to_string(tree.depth_levels) + " levels";
    }
  }
  return {};
}

// Leaves carry words (each id once), inner nodes none; weights finite and >= 0.
std::string check_words(const VocabularyTree& tree, const std::vector<std::size_t>& children) {
  std::vector<bool> seen(tree.words(), false);
  std::size_t leaves = 0;
  for (std::size_t i = 0; i < tree.nodes(); ++i) {
    const WordId w = tree.word[i];
    if (children[i] > 0) {
      if (w != kNoWord) return node_text(i) + ": an inner node with word " + std::to_string(w);
      continue;
    }
    ++leaves;
    if (w == kNoWord) return node_text(i) + ": a leaf without a word";
    if (w >= tree.words()) {
      return node_text(i) + ": word " + std::to_string(w) + " out of range (" + std::to_string(tree.words()) +
             " words)";
    }
    if (seen[w]) return node_text(i) + ": word " + std::to_string(w) + " given to two leaves";
    seen[w] = true;
  }
  if (leaves != tree.words()) {
    return std::to_string(leaves) + " leaves for " + std::to_string(tree.words()) + " word weights";
  }
  for (std::size_t w = 0; w < tree.words(); ++w) {
    const double weight = tree.word_weight[w];
    if (!(std::isfinite(weight) && weight >= 0.0)) return "word " + std::to_string(w) + ": weight not finite and >= 0";
  }
  return {};
}

}  // namespace

std::string check_vocabulary_tree(const VocabularyTree& tree) {
  if (tree.branching < 1 || tree.branching > 65535) return "k = " + std::to_string(tree.branching) + " not in [1, 65535]";
  if (tree.depth_levels < 1 || tree.depth_levels > 64) return "L = " + std::to_string(tree.depth_levels) + " not in [1, 64]";
  const std::size_t n = tree.nodes();
  if (n < 2) return "no nodes below the root";
  if (n >= kNoNode) return "too many nodes";
  if (tree.descriptors.size() != n * kDescriptorBytes) return "descriptor array does not hold one per node";
  if (tree.word.size() != n) return "word array does not hold one entry per node";
  std::vector<std::size_t> children;
  std::vector<int> depth;
  std::string why = check_parents(tree, children, depth);
  return why.empty() ? check_words(tree, children) : why;
}

Vocabulary::Vocabulary(VocabularyTree tree) : tree_(std::move(tree)) {
  const std::string why = check_vocabulary_tree(tree_);
  if (!why.empty()) throw InputError("vocabulary", why);
  const std::size_t n = tree_.nodes();
  child_begin_.assign(n, 0);
  child_end_.assign(n, 0);
  depth_.assign(n, 0);
  for (std::size_t i = n; i-- > 1;) {  // backwards: the last assignment is the first child
    const NodeId p = tree_.parent[i];
    if (child_end_[p] == 0) child_end_[p] = static_cast<NodeId>(i + 1);
    child_begin_[p] = static_cast<NodeId>(i);
  }
  for (std::size_t i = 1; i < n; ++i) depth_[i] = depth_[tree_.parent[i]] + 1;
  word_node_.assign(tree_.words(), kNoNode);
  for (std::size_t i = 0; i < n; ++i) {
    if (tree_.word[i] != kNoWord) word_node_[tree_.word[i]] = static_cast<NodeId>(i);
  }
}

NodeId Vocabulary::descend(const std::uint8_t* descriptor, int group_depth, NodeId& group) const {
  NodeId node = 0;
  int d = 0;
  group = group_depth <= 0 ? 0 : kNoNode;
  const std::uint8_t* const centres = tree_.descriptors.data();
  while (child_begin_[node] != child_end_[node]) {
    NodeId best = child_begin_[node];
    int best_distance = hamming_distance(descriptor, centres + std::size_t{best} * kDescriptorBytes);
    for (NodeId c = best + 1; c < child_end_[node]; ++c) {
      const int distance = hamming_distance(descriptor, centres + std::size_t{c} * kDescriptorBytes);
      if (distance < best_distance) {
        best_distance = distance;
        best = c;
      }
    }
    node = best;
    if (++d == group_depth) group = node;
  }
  if (group == kNoNode) group = node;
  return node;
}

WordId Vocabulary::word_of(const std::uint8_t* descriptor) const {
  if (empty()) return kNoWord;
  NodeId group = 0;
  return tree_.word[descend(descriptor, 0, group)];
}

namespace {

void check_descriptors(const cv::Mat& descriptors) {
  if (descriptors.empty()) return;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes || descriptors.dims != 2) {
    throw InputError("vocabulary transform", "descriptors must be N x " + std::to_string(kDescriptorBytes) +
                                                 " CV_8UC1, got " + std::to_string(descriptors.rows) + " x " +
                                                 std::to_string(descriptors.cols) + " of type " +
                                                 std::to_string(descriptors.type()));
  }
}

// tf * idf per word (tf = occurrences / features), L1-normalised; zero weights left out.
BowVector weigh(std::vector<WordId> words, const std::vector<double>& idf) {
  BowVector bow;
  const double features = static_cast<double>(words.size());
  std::sort(words.begin(), words.end());
  double sum = 0.0;
  for (std::size_t i = 0; i < words.size();) {
    std::size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const double weight = idf[words[i]] * static_cast<double>(j - i) / features;
    if (weight > 0.0) {
      bow.entries.push_back({words[i], weight});
      sum += weight;
    }
    i = j;
  }
  if (sum > 0.0) {
    for (BowEntry& e : bow.entries) e.weight /= sum;
  }
  return bow;
}

FeatureVector group_features(const std::vector<NodeId>& groups) {
  std::vector<std::pair<NodeId, int>> pairs(groups.size());
  for (std::size_t i = 0; i < groups.size(); ++i) pairs[i] = {groups[i], static_cast<int>(i)};
  std::sort(pairs.begin(), pairs.end());
  FeatureVector fv;
  for (const auto& [node, feature] : pairs) {
    if (fv.nodes.empty() || fv.nodes.back().node != node) fv.nodes.push_back({node, {}});
    fv.nodes.back().features.push_back(feature);
  }
  return fv;
}

}  // namespace

BowTransform Vocabulary::transform(const cv::Mat& descriptors, int levels_up) const {
  check_descriptors(descriptors);
  BowTransform result;
  const int rows = descriptors.empty() ? 0 : descriptors.rows;
  if (empty()) {
    result.words.assign(static_cast<std::size_t>(rows), kNoWord);
    return result;
  }
  const int group_depth = std::max(0, tree_.depth_levels - std::max(0, levels_up));
  result.words.resize(static_cast<std::size_t>(rows));
  std::vector<NodeId> groups(static_cast<std::size_t>(rows));
  for (int i = 0; i < rows; ++i) {
    const NodeId leaf = descend(descriptors.ptr<std::uint8_t>(i), group_depth, groups[static_cast<std::size_t>(i)]);
    result.words[static_cast<std::size_t>(i)] = tree_.word[leaf];
  }
  result.bow = weigh(result.words, tree_.word_weight);
  result.features = group_features(groups);
  return result;
}

BowVector Vocabulary::bow(const cv::Mat& descriptors) const {
  check_descriptors(descriptors);
  if (empty() || descriptors.empty()) return {};
  std::vector<WordId> words(static_cast<std::size_t>(descriptors.rows));
  for (int i = 0; i < descriptors.rows; ++i) words[static_cast<std::size_t>(i)] = word_of(descriptors.ptr<std::uint8_t>(i));
  return weigh(std::move(words), tree_.word_weight);
}

}  // namespace fleetslam::slam
