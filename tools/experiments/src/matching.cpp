#include "fleetslam/experiments/matching.hpp"

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>

#include <opencv2/core/utility.hpp>

#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/experiments/svg_plot.hpp"
#include "fleetslam/slam/frame_builder.hpp"

namespace fleetslam::experiments {
namespace {

namespace fs = std::filesystem;

// Restores OpenCV's thread count on scope exit (the projection matchers are single-threaded: compare per core).
class SingleThreadedOpenCv {
 public:
  SingleThreadedOpenCv() : previous_(cv::getNumThreads()) { cv::setNumThreads(1); }
  ~SingleThreadedOpenCv() { cv::setNumThreads(previous_); }
  SingleThreadedOpenCv(const SingleThreadedOpenCv&) = delete;
  SingleThreadedOpenCv& operator=(const SingleThreadedOpenCv&) = delete;

 private:
  int previous_;
};

// Frame index k of each pair (k, k+1); k >= 1 so that k-1 gives the constant-velocity prediction.
std::vector<std::int64_t> pair_starts(std::int64_t frames, int pairs) {
  std::vector<std::int64_t> starts;
  if (frames < 3) return starts;
  const std::int64_t span = frames - 2;  // k in [1, frames - 2]
  for (int i = 0; i < pairs; ++i) {
    const std::int64_t k = 1 + (span * (2 * i + 1)) / (2 * pairs);
    if (starts.empty() || starts.back() != k) starts.push_back(k);
  }
  return starts;
}

struct Triple {
  core::SensorFrame previous, a, b;
};

// Frames k-1, k, k+1, each with a ground-truth pose; none when one of them has no pose.
std::optional<Triple> read_triple(const SequenceSpec& spec, std::int64_t k, const core::Logger& logger) {
  const auto source = open_sequence(spec, k - 1, k + 2, logger);
  Triple t;
  core::SensorFrame* slots[] = {&t.previous, &t.a, &t.b};
  for (core::SensorFrame* slot : slots) {
    std::optional<core::SensorFrame> frame = source->next();
    if (!frame) throw InputError(spec.folder.string(), "frame " + std::to_string(k) + " and its neighbours cannot be read");
    if (!frame->T_world_cam_gt) return std::nullopt;
    *slot = std::move(*frame);
  }
  return t;
}

// The pairs at `starts`; a start whose frames lack a ground-truth pose (a motion-capture drop-out) moves
// on to the next frames that have one, up to the next start.
std::vector<Triple> read_triples(const SequenceSpec& spec, const std::vector<std::int64_t>& starts, std::int64_t frames,
                                 const core::Logger& logger) {
  std::vector<Triple> triples;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    const std::int64_t last = i + 1 < starts.size() ? starts[i + 1] - 1 : frames - 2;
    std::int64_t k = starts[i];
    std::optional<Triple> triple = read_triple(spec, k, logger);
    while (!triple && k < last) triple = read_triple(spec, ++k, logger);
    if (!triple) {
      logger->warn("{}: no three consecutive frames with ground truth from frame {} to {}: pair left out",
                   spec.folder.string(), starts[i] - 1, last + 1);
      continue;
    }
    if (k != starts[i]) {
      logger->warn("{}: frames {} .. {} lack a ground-truth pose: the pair starts at frame {} instead", spec.folder.string(),
                   starts[i] - 1, starts[i] + 1, k);
    }
    triples.push_back(std::move(*triple));
  }
  if (triples.empty()) {
    throw InputError(spec.folder.string(), "no three consecutive frames with a ground-truth pose: matching needs them");
  }
  return triples;
}

MatchPair make_pair(const slam::FrameBuilder& builder, const Triple& t) {
  MatchPair pair;
  pair.a = builder.build(t.a).frame;
  pair.b = builder.build(t.b).frame;
  pair.p_a = slam::points_from_depth(pair.a);
  pair.p_b = slam::points_from_depth(pair.b);
  pair.T_a_b_true = t.a.T_world_cam_gt->inverse() * *t.b.T_world_cam_gt;
  pair.T_a_b_predicted = t.previous.T_world_cam_gt->inverse() * *t.a.T_world_cam_gt;
  return pair;
}

slam::FrameBuilderConfig builder_config(const SequenceSpec& spec, int features) {
  slam::FrameBuilderConfig config = agent_config_for(spec).frontend;
  config.orb.num_features = features;
  return config;
}

// The selected matchers in all_matchers' order.
std::vector<MatcherKind> selected_matchers(const std::vector<MatcherKind>& selection) {
  std::vector<MatcherKind> kinds;
  for (const MatcherKind kind : all_matchers()) {
    if (std::find(selection.begin(), selection.end(), kind) != selection.end()) kinds.push_back(kind);
  }
  return kinds;
}

// What cross-validation adds to the single-stage grid matcher's median time, per feature count (the
// paper's cost of the method: 1.05 -> 1.24 ms, +18 %, at 1000 features), as a Markdown paragraph; empty
// when no feature count has both rows.
std::string cross_validation_overhead(const MatchingResult& result, const std::string& sequence) {
  std::string parts;
  for (const int n : result.config.features) {
    const MatchingRow* grid = nullptr;
    const MatchingRow* checked = nullptr;
    for (const MatchingRow& r : result.rows) {
      if (r.sequence != sequence || r.features != n) continue;
      if (r.matcher == MatcherKind::kGrid) grid = &r;
      if (r.matcher == MatcherKind::kCrossValidation) checked = &r;
    }
    if (grid == nullptr || checked == nullptr || !(grid->median_ms > 0.0)) continue;
    const double percent = 100.0 * (checked->median_ms / grid->median_ms - 1.0);
    parts += std::string(parts.empty() ? "" : ", ") + (percent >= 0.0 ? "+" : "") + fixed(percent, 1) + " % at " +
             std::to_string(n) + " features";
  }
  if (parts.empty()) return "";
  return "\nCross-validation adds to the single-stage grid matcher's median time: " + parts + ".\n";
}

}  // namespace

std::string file_stem(const std::string& sequence) {
  std::string stem;
  for (const char c : sequence) stem += (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_') ? c : '_';
  return stem;
}

MatchingExperiment::MatchingExperiment(const MatchingConfig& config, core::Logger logger)
    : config_(config), logger_(std::move(logger)) {
  if (config_.features.empty()) throw InputError("--features", "give at least one feature count");
  for (const int n : config_.features) {
    if (n < 10 || n > 100000) throw InputError("--features", "feature counts must be in [10, 100000], got " + std::to_string(n));
  }
  if (config_.repetitions < 1) throw InputError("--repetitions", "must be at least 1");
  if (config_.pairs < 1) throw InputError("--pairs", "must be at least 1");
  if (config_.matchers.empty()) throw InputError("--matchers", "needs at least one matcher");
  for (std::size_t i = 0; i < config_.matchers.size(); ++i) {
    if (std::count(config_.matchers.begin(), config_.matchers.begin() + static_cast<std::ptrdiff_t>(i),
                   config_.matchers[i]) > 0) {
      throw InputError("--matchers", to_string(config_.matchers[i]) + " is named twice");
    }
  }
}

MatchingResult MatchingExperiment::run(const std::vector<SequenceSpec>& sequences) const {
  const SingleThreadedOpenCv single_threaded;
  MatchingResult result;
  result.config = config_;
  for (const SequenceSpec& spec : sequences) {
    const auto probe = open_sequence(spec, 0, config_.max_frames, logger_);
    const std::vector<std::int64_t> starts = pair_starts(static_cast<std::int64_t>(probe->size()), config_.pairs);
    if (starts.empty()) throw InputError(spec.folder.string(), "matching needs at least 3 frames");
    const std::vector<Triple> triples = read_triples(spec, starts, static_cast<std::int64_t>(probe->size()), logger_);
    for (const int features : config_.features) {
      const slam::FrameBuilder builder(builder_config(spec, features), probe->rig());
      std::vector<MatchPair> pairs;
      for (const Triple& t : triples) pairs.push_back(make_pair(builder, t));
      // The two projection matchers are timed interleaved, in turns that alternate which one goes first
      // (grid, cross-validation, cross-validation, grid, ...): they then share the machine's slow spells
      // and each follows itself and the other equally often. Timed one after the other, cross-validation's
      // overhead over the grid matcher varied by tens of percent from run to run on a shared machine.
      // The other matchers (each far slower, with another memory footprint that would leave the
      // projection matchers' data out of the caches) are timed in runs of their own.
      const std::vector<MatcherKind> kinds = selected_matchers(config_.matchers);
      std::vector<std::vector<std::size_t>> groups;
      std::vector<std::size_t> projection;
      for (std::size_t k = 0; k < kinds.size(); ++k) {
        const bool is_projection = kinds[k] == MatcherKind::kGrid || kinds[k] == MatcherKind::kCrossValidation;
        if (is_projection) {
          projection.push_back(k);
        } else {
          groups.push_back({k});
        }
      }
      groups.push_back(projection);
      std::vector<std::vector<double>> times_ms(kinds.size());
      std::vector<MatchQuality> quality(kinds.size());
      for (const MatchPair& pair : pairs) {
        std::vector<std::vector<slam::Match>> matches(kinds.size());
        for (const std::vector<std::size_t>& group : groups) {
          for (int r = 0; r < config_.repetitions; ++r) {
            for (std::size_t j = 0; j < group.size(); ++j) {
              const std::size_t k = r % 2 == 0 ? group[j] : group[group.size() - 1 - j];
              const auto start = std::chrono::steady_clock::now();
              matches[k] = run_matcher(kinds[k], pair, config_.settings);
              times_ms[k].push_back(
                  std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
            }
          }
        }
        for (std::size_t k = 0; k < kinds.size(); ++k) quality[k] += evaluate_matches(pair, matches[k], config_.correct_px);
      }
      std::vector<double> features_a, features_b;
      for (const MatchPair& pair : pairs) {
        features_a.push_back(static_cast<double>(pair.a.uv.size()));
        features_b.push_back(static_cast<double>(pair.b.uv.size()));
      }
      for (std::size_t k = 0; k < kinds.size(); ++k) {
        MatchingRow row;
        row.sequence = spec.name;
        row.origin = spec.origin;
        row.features = features;
        row.matcher = kinds[k];
        row.pairs = static_cast<int>(pairs.size());
        row.quality = quality[k];
        row.features_a_mean = mean_of(features_a);
        row.features_b_mean = mean_of(features_b);
        row.mean_ms = mean_of(times_ms[k]);
        row.median_ms = median_of(times_ms[k]);
        logger_->info("matching {} {} features {}: median {:.3f} ms, {} matches, precision {:.3f}, recall {:.3f}",
                      spec.name, features, to_string(kinds[k]), row.median_ms, row.quality.matches,
                      row.quality.precision(), row.quality.recall());
        result.rows.push_back(row);
      }
    }
  }
  return result;
}

Table matching_table(const MatchingResult& result) {
  Table table;
  table.header = {"sequence", "origin", "features", "matcher", "pairs", "repetitions", "features_a_mean",
                  "features_b_mean", "matches", "verifiable", "correct", "with_partner", "correct_with_partner",
                  "precision", "recall", "mean_ms", "median_ms"};
  for (const MatchingRow& r : result.rows) {
    const MatchQuality& q = r.quality;
    table.rows.push_back({r.sequence, r.origin, std::to_string(r.features), to_string(r.matcher), std::to_string(r.pairs),
                          std::to_string(result.config.repetitions), fixed(r.features_a_mean, 1),
                          fixed(r.features_b_mean, 1), std::to_string(q.matches), std::to_string(q.verifiable),
                          std::to_string(q.correct), std::to_string(q.with_partner),
                          std::to_string(q.correct_with_partner), fixed(q.precision(), 4), fixed(q.recall(), 4),
                          fixed(r.mean_ms, 4), fixed(r.median_ms, 4)});
  }
  return table;
}

std::vector<fs::path> write_matching_outputs(const MatchingResult& result, const fs::path& dir) {
  std::vector<fs::path> written = {dir / "matching.csv", dir / "matching.md"};
  write_text(written[0], matching_table(result).csv());
  std::vector<std::string> names;
  for (const MatchingRow& row : result.rows) names.push_back(row.sequence);
  const std::vector<std::string> sequences = unique_in_order(names);
  std::string md = "# Matching time and quality (paper Table 1)\n\n"
                   "Median ms per match over " + std::to_string(result.config.repetitions) +
                   " repetitions of each pair; matches, precision and recall summed over the pairs "
                   "(correct within " + fixed(result.config.correct_px, 1) + " px of the ground-truth transfer).\n";
  for (const std::string& sequence : sequences) {
    Table table;
    table.header = {"matcher"};
    for (const int n : result.config.features) {
      table.header.push_back(std::to_string(n) + " ms");
      table.header.push_back(std::to_string(n) + " matches");
      table.header.push_back(std::to_string(n) + " precision");
      table.header.push_back(std::to_string(n) + " recall");
    }
    LinePlot time_plot{"Matching time, " + sequence, "features per frame", "median ms per match", {}};
    LinePlot precision_plot{"Matching precision, " + sequence, "features per frame", "precision", {}};
    for (const MatcherKind kind : selected_matchers(result.config.matchers)) {
      std::vector<std::string> cells = {to_string(kind)};
      PlotSeries time_series{to_string(kind), {}, {}}, precision_series{to_string(kind), {}, {}};
      for (const MatchingRow& r : result.rows) {
        if (r.sequence != sequence || r.matcher != kind) continue;
        cells.push_back(fixed(r.median_ms, 4));
        cells.push_back(std::to_string(r.quality.matches));
        cells.push_back(fixed(r.quality.precision(), 3));
        cells.push_back(fixed(r.quality.recall(), 3));
        time_series.x.push_back(r.features);
        time_series.y.push_back(r.median_ms);
        precision_series.x.push_back(r.features);
        precision_series.y.push_back(r.quality.precision());
      }
      table.rows.push_back(cells);
      time_plot.series.push_back(time_series);
      precision_plot.series.push_back(precision_series);
    }
    md += "\n## " + sequence + "\n\n" + table.markdown() + cross_validation_overhead(result, sequence);
    const fs::path time_svg = dir / ("matching_time_" + file_stem(sequence) + ".svg");
    const fs::path precision_svg = dir / ("matching_precision_" + file_stem(sequence) + ".svg");
    write_text(time_svg, render_svg(time_plot));
    write_text(precision_svg, render_svg(precision_plot));
    written.push_back(time_svg);
    written.push_back(precision_svg);
  }
  write_text(written[1], md);
  return written;
}

}  // namespace fleetslam::experiments
