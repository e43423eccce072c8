// Vocabulary training: hierarchical k-medians over binary descriptors (DBoW2 paper, section IV), split
// breadth first so that the tree comes out in the layout VocabularyTree describes, then the IDF weights.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {
namespace {

constexpr std::size_t kBytes = kDescriptorBytes;
constexpr std::size_t kBits = kBytes * 8;

// Throws InputError("vocabulary.<key>", ...) for a field outside its limits.
struct LimitCheck {
  template <class T>
  void operator()(const char* key, const T& value, core::Limits<T> limits = {}) const {
    if (value < limits.min || value > limits.max) {
      throw InputError(std::string("vocabulary.") + key, "must be in [" + std::to_string(limits.min) + ", " +
                                                             std::to_string(limits.max) + "], got " +
                                                             std::to_string(value));
    }
  }
};

// All training descriptors in one contiguous array.
struct TrainingSet {
  std::vector<std::uint8_t> bytes;
  std::size_t size() const { return bytes.size() / kBytes; }
  const std::uint8_t* operator[](std::uint32_t i) const { return bytes.data() + std::size_t{i} * kBytes; }
};

TrainingSet gather(const std::vector<cv::Mat>& images) {
  std::size_t total = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const cv::Mat& m = images[i];
    if (m.empty()) continue;
    if (m.type() != CV_8UC1 || m.cols != kDescriptorBytes || m.dims != 2) {
      throw InputError("vocabulary training", "image " + std::to_string(i) + ": descriptors must be N x 32 CV_8UC1");
    }
    total += static_cast<std::size_t>(m.rows);
  }
  if (total == 0) throw InputError("vocabulary training", "no descriptors to train from");
  if (total >= std::size_t{1} << 32) throw InputError("vocabulary training", "more than 2^32 descriptors");
  TrainingSet set;
  set.bytes.reserve(total * kBytes);
  for (const cv::Mat& m : images) {
    for (int r = 0; !m.empty() && r < m.rows; ++r) set.bytes.insert(set.bytes.end(), m.ptr<std::uint8_t>(r), m.ptr<std::uint8_t>(r) + kBytes);
  }
  return set;
}

// 64 random bits from two draws (the standard fixes mt19937's output sequence, unlike its distributions).
std::uint64_t draw64(std::mt19937& rng) { return (std::uint64_t{rng()} << 32) | rng(); }

std::mt19937 node_generator(std::int64_t seed, std::size_t node) {
  const auto s = static_cast<std::uint64_t>(seed);
  std::seed_seq seq{static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(s >> 32),
                    static_cast<std::uint32_t>(node), static_cast<std::uint32_t>(std::uint64_t{node} >> 32)};
  return std::mt19937(seq);
}

bool all_equal(const TrainingSet& set, const std::vector<std::uint32_t>& members) {
  const std::uint8_t* first = set[members[0]];
  return std::all_of(members.begin() + 1, members.end(),
                     [&](std::uint32_t i) { return std::memcmp(set[i], first, kBytes) == 0; });
}

// Byte value -> its bits spread into the 8 bytes of a word (bit b into byte b): adds 8 bit counters at once.
constexpr std::array<std::uint64_t, 256> make_spread() {
  std::array<std::uint64_t, 256> t{};
  for (std::size_t v = 0; v < 256; ++v) {
    for (std::size_t b = 0; b < 8; ++b) t[v] |= std::uint64_t{(v >> b) & 1u} << (8 * b);
  }
  return t;
}
constexpr std::array<std::uint64_t, 256> kSpread = make_spread();

// One node's k-medians: centres (kBytes each) and each member's cluster.
class KMedians {
 public:
  KMedians(const TrainingSet& set, const std::vector<std::uint32_t>& members) : set_(set), members_(members) {}

  // k-means++ (Arthur and Vassilvitskii 2007): each next centre drawn with probability proportional to
  // the squared distance to the nearest centre so far; stops early when every member sits on a centre.
  void seed(int k, std::mt19937& rng) {
    const std::size_t m = members_.size();
    add_centre(set_[members_[draw64(rng) % m]]);
    std::vector<std::uint64_t> d2(m);
    for (std::size_t i = 0; i < m; ++i) d2[i] = squared(distance_to(i, 0));
    while (centres() < static_cast<std::size_t>(k)) {
      std::uint64_t total = 0;
      for (const std::uint64_t d : d2) total += d;
      if (total == 0) break;
      std::uint64_t r = draw64(rng) % total;
      std::size_t pick = 0;
      while (r >= d2[pick]) r -= d2[pick++];
      add_centre(set_[members_[pick]]);
      const std::size_t c = centres() - 1;
      for (std::size_t i = 0; i < m; ++i) d2[i] = std::min(d2[i], squared(distance_to(i, c)));
    }
  }

  // Nearest centre of each member (ties: the lower centre); true when an assignment changed.
  bool assign() {
    bool changed = assignment_.empty();
    assignment_.resize(members_.size());
    for (std::size_t i = 0; i < members_.size(); ++i) {
      std::uint32_t best = 0;
      int best_distance = distance_to(i, 0);
      for (std::size_t c = 1; c < centres(); ++c) {
        const int d = distance_to(i, c);
        if (d < best_distance) {
          best_distance = d;
          best = static_cast<std::uint32_t>(c);
        }
      }
      changed = changed || assignment_[i] != best;
      assignment_[i] = best;
    }
    return changed;
  }

  // Each centre becomes the bitwise majority of its members (ties set the bit); empty clusters keep theirs.
  void update_medians() {
    const std::size_t k = centres();
    std::vector<std::uint32_t> counts(k * kBits, 0);
    std::vector<std::uint64_t> lanes(k * kBytes, 0);  // 8 bit counters per byte, flushed before they overflow
    std::vector<std::uint32_t> pending(k, 0), sizes(k, 0);
    const auto flush = [&](std::size_t c) {
      for (std::size_t j = 0; j < kBytes; ++j) {
        std::uint64_t& lane = lanes[c * kBytes + j];
        for (std::size_t b = 0; b < 8; ++b) counts[c * kBits + j * 8 + b] += static_cast<std::uint32_t>((lane >> (8 * b)) & 0xFF);
        lane = 0;
      }
      pending[c] = 0;
    };
    for (std::size_t i = 0; i < members_.size(); ++i) {
      const std::uint32_t c = assignment_[i];
      const std::uint8_t* x = set_[members_[i]];
      std::uint64_t* lane = &lanes[std::size_t{c} * kBytes];
      for (std::size_t j = 0; j < kBytes; ++j) lane[j] += kSpread[x[j]];
      ++sizes[c];
      if (++pending[c] == 255) flush(c);
    }
    for (std::size_t c = 0; c < k; ++c) {
      if (sizes[c] == 0) continue;
      flush(c);
      std::uint8_t* centre = &centres_[c * kBytes];
      for (std::size_t j = 0; j < kBytes; ++j) {
        std::uint8_t byte = 0;
        for (std::size_t b = 0; b < 8; ++b) {
          if (2 * counts[c * kBits + j * 8 + b] >= sizes[c]) byte = static_cast<std::uint8_t>(byte | (1u << b));
        }
        centre[j] = byte;
      }
    }
  }

  std::size_t centres() const { return centres_.size() / kBytes; }
  const std::uint8_t* centre(std::size_t c) const { return &centres_[c * kBytes]; }
  const std::vector<std::uint32_t>& assignment() const { return assignment_; }

 private:
  void add_centre(const std::uint8_t* d) { centres_.insert(centres_.end(), d, d + kBytes); }
  int distance_to(std::size_t member, std::size_t c) const { return hamming_distance(set_[members_[member]], centre(c)); }
  static std::uint64_t squared(int d) { return static_cast<std::uint64_t>(d) * static_cast<std::uint64_t>(d); }
  const TrainingSet& set_;
  const std::vector<std::uint32_t>& members_;
  std::vector<std::uint8_t> centres_;
  std::vector<std::uint32_t> assignment_;
};

struct Cluster {
  const std::uint8_t* centre = nullptr;
  std::vector<std::uint32_t> members;
};

// The non-empty clusters of one node, in centre order.
std::vector<Cluster> split(const std::vector<std::uint32_t>& members, const VocabularyConfig& config,
                           std::mt19937& rng, KMedians& km) {
  km.seed(config.branching, rng);
  km.assign();
  for (int it = 0; it < config.max_iterations; ++it) {
    km.update_medians();
    if (!km.assign()) break;
  }
  std::vector<Cluster> clusters(km.centres());
  for (std::size_t i = 0; i < members.size(); ++i) clusters[km.assignment()[i]].members.push_back(members[i]);
  for (std::size_t c = 0; c < clusters.size(); ++c) clusters[c].centre = km.centre(c);
  clusters.erase(std::remove_if(clusters.begin(), clusters.end(), [](const Cluster& c) { return c.members.empty(); }),
                 clusters.end());
  return clusters;
}

// The tree without weights: words numbered in node (breadth-first) order.
VocabularyTree build_tree(const TrainingSet& set, const VocabularyConfig& config, core::Progress& progress) {
  VocabularyTree tree;
  tree.branching = config.branching;
  tree.depth_levels = config.depth_levels;
  tree.parent = {kNoNode};
  tree.descriptors.assign(kBytes, 0);
  std::vector<int> depth = {0};
  std::vector<std::vector<std::uint32_t>> members(1);
  members[0].resize(set.size());
  for (std::uint32_t i = 0; i < members[0].size(); ++i) members[0][i] = i;
  const auto levels = static_cast<std::size_t>(config.depth_levels);
  std::size_t done = 0;
  for (std::size_t node = 0; node < tree.parent.size(); ++node) {  // grows while it runs: breadth first
    const std::vector<std::uint32_t> own = std::move(members[node]);
    members[node] = {};
    const auto d = static_cast<std::size_t>(depth[node]);
    if (d == levels || all_equal(set, own)) {
      done += own.size() * (levels - d);
      progress.update(done);
      continue;
    }
    std::mt19937 rng = node_generator(config.seed, node);
    KMedians km(set, own);
    for (Cluster& c : split(own, config, rng, km)) {
      tree.parent.push_back(static_cast<NodeId>(node));
      tree.descriptors.insert(tree.descriptors.end(), c.centre, c.centre + kBytes);
      depth.push_back(depth[node] + 1);
      members.push_back(std::move(c.members));
    }
    done += own.size();
    progress.update(done);
  }
  std::vector<bool> inner(tree.nodes(), false);
  for (std::size_t i = 1; i < tree.nodes(); ++i) inner[tree.parent[i]] = true;
  tree.word.assign(tree.nodes(), kNoWord);
  WordId words = 0;
  for (std::size_t i = 0; i < tree.nodes(); ++i) {
    if (!inner[i]) tree.word[i] = words++;
  }
  tree.word_weight.assign(words, 1.0);
  return tree;
}

}  // namespace

VocabularyTrainer::VocabularyTrainer(const VocabularyConfig& config, core::Logger logger)
    : config_(config), logger_(logger ? std::move(logger) : core::null_logger()) {
  LimitCheck check;
  config_.visit(check);
}

Vocabulary VocabularyTrainer::train(const std::vector<cv::Mat>& descriptors_per_image) const {
  const TrainingSet set = gather(descriptors_per_image);
  logger_->info("vocabulary: training k = {}, L = {} on {} descriptors of {} images", config_.branching,
                config_.depth_levels, set.size(), descriptors_per_image.size());
  core::Progress progress("vocabulary training", set.size() * static_cast<std::size_t>(config_.depth_levels),
                          core::Progress::log_sink(logger_));
  VocabularyTree tree = build_tree(set, config_, progress);
  progress.finish();

  // IDF (paper eq. 2): ln(N / n_w), n_w counting the images whose descriptors reach word w.
  const Vocabulary unweighted(tree);
  std::vector<std::uint64_t> images_with(tree.words(), 0);
  std::vector<std::size_t> last_image(tree.words(), static_cast<std::size_t>(-1));
  std::uint64_t images = 0;
  for (std::size_t i = 0; i < descriptors_per_image.size(); ++i) {
    const cv::Mat& m = descriptors_per_image[i];
    if (m.empty() || m.rows == 0) continue;
    ++images;
    for (int r = 0; r < m.rows; ++r) {
      const WordId w = unweighted.word_of(m.ptr<std::uint8_t>(r));
      if (last_image[w] != i) {
        last_image[w] = i;
        ++images_with[w];
      }
    }
  }
  for (std::size_t w = 0; w < tree.words(); ++w) {
    // Every word holds a training descriptor; the guard keeps a word no image reached at the largest IDF.
    const double n_w = static_cast<double>(std::max<std::uint64_t>(images_with[w], 1));
    tree.word_weight[w] = std::log(static_cast<double>(images) / n_w);
  }
  tree.training_images = images;
  tree.training_descriptors = set.size();
  logger_->info("vocabulary: {} nodes, {} words", tree.nodes(), tree.words());
  return Vocabulary(std::move(tree));
}

}  // namespace fleetslam::slam
