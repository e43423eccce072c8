// fleetslam vocab train|info: train a bag-of-words vocabulary from the ORB features of images (folders of
// png/jpg, or recorded sequences) with the project's own extractor and trainer; describe a vocabulary file.

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/logger.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/orb_extractor.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;

struct VocabOptions {
  std::vector<std::string> image_folders;
  std::vector<std::string> datasets;
  std::string format;  // of the datasets; empty: detect
  std::string out;
  int k = 10;
  int levels = 5;
  int features = 1000;
  std::int64_t max_images = -1;
  std::int64_t seed = 0;
  std::string file;  // info
  bool json = false;
};

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool is_image_file(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

// The png/jpg files directly in a folder, sorted by name.
std::vector<fs::path> list_images(const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw InputError(folder.string(), "not a folder");
  std::vector<fs::path> images;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    if (entry.is_regular_file(ec) && is_image_file(entry.path())) images.push_back(entry.path());
  }
  if (ec) throw InputError(folder.string(), "cannot list the folder: " + ec.message());
  std::sort(images.begin(), images.end());
  return images;
}

// Every stride-th image of the concatenated sources is used: stride ceil(total / max_images), or 1 for all.
std::size_t image_stride(std::size_t total, std::int64_t max_images) {
  if (max_images <= 0 || static_cast<std::size_t>(max_images) >= total) return 1;
  const auto n = static_cast<std::size_t>(max_images);
  return (total + n - 1) / n;
}

// ORB descriptors of every selected image, folders first (in the order given), then datasets (cam0).
class DescriptorCollector {
 public:
  DescriptorCollector(const VocabOptions& o, const core::Logger& logger) : o_(o), logger_(logger), extractor_(orb(o)) {}

  std::vector<cv::Mat> collect() {
    std::vector<fs::path> files;
    for (const std::string& folder : o_.image_folders) {
      const std::vector<fs::path> found = list_images(folder);
      if (found.empty()) throw InputError(folder, "no png/jpg images in the folder");
      files.insert(files.end(), found.begin(), found.end());
    }
    // Sequence lengths from their lists alone (no image decoded), then the selection.
    std::size_t total = files.size();
    std::vector<std::size_t> offsets;
    for (const std::string& dataset : o_.datasets) {
      offsets.push_back(total);
      total += open(dataset, false, 0, 1)->size();
    }
    if (total == 0) throw InputError("vocab train", "no images: give --images folders or --dataset sequences");
    const std::size_t stride = image_stride(total, o_.max_images);
    progress_ = std::make_unique<core::Progress>("ORB extraction", (total + stride - 1) / stride,
                                                 core::Progress::log_sink(logger_));
    for (std::size_t i = 0; i < files.size(); i += stride) add(read_image(files[i]), files[i].string());
    for (std::size_t s = 0; s < o_.datasets.size(); ++s) {
      const std::size_t start = (stride - offsets[s] % stride) % stride;  // first global index on the stride
      const auto source = open(o_.datasets[s], true, start, stride);
      while (auto frame = source->next()) add(frame->image, frame->image_path.empty() ? o_.datasets[s] : frame->image_path);
    }
    progress_->finish();
    return std::move(descriptors_);
  }

 private:
  static slam::OrbExtractorConfig orb(const VocabOptions& o) {
    slam::OrbExtractorConfig config;
    config.num_features = o.features;
    return config;
  }

  std::unique_ptr<core::FrameSource> open(const std::string& dataset, bool images, std::size_t start,
                                          std::size_t stride) const {
    core::DatasetConfig config;
    config.load_images = images;
    config.load_imu = false;
    config.stereo = false;
    config.start_index = static_cast<std::int64_t>(start);
    config.stride = static_cast<std::int64_t>(stride);
    std::optional<core::DatasetFormat> format;
    if (!o_.format.empty()) format = core::dataset_format_from_string(o_.format);
    return core::open_dataset(dataset, format, config, images ? logger_ : core::null_logger());
  }

  static cv::Mat read_image(const fs::path& file) {
    cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) throw InputError(file.string(), "cannot decode the image");
    return image;
  }

  void add(const cv::Mat& image, const std::string& where) {
    try {
      descriptors_.push_back(extractor_.extract(image).descriptors);
    } catch (const InputError& e) {
      throw InputError(where, e.why());
    }
    progress_->update(descriptors_.size());
  }

  const VocabOptions& o_;
  core::Logger logger_;
  slam::OrbExtractor extractor_;
  std::unique_ptr<core::Progress> progress_;
  std::vector<cv::Mat> descriptors_;
};

void run_train(const VocabOptions& o, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("vocab", global);
  if (o.max_images != -1 && o.max_images < 1) throw InputError("--max-images", "must be -1 (all) or at least 1");
  if (o.image_folders.empty() && o.datasets.empty()) {
    throw InputError("vocab train", "no images: give --images folders or --dataset sequences");
  }
  slam::VocabularyConfig config;
  config.branching = o.k;
  config.depth_levels = o.levels;
  config.seed = o.seed;
  const slam::VocabularyTrainer trainer(config, logger);  // checks the limits before the long work
  // So is where the vocabulary goes: a folder, or a folder that cannot be made, would fail only after it.
  const fs::path out(o.out);
  std::error_code ec;
  if (fs::is_directory(out, ec)) throw InputError(o.out, "--out is a folder; give a file name");
  if (out.has_parent_path()) {
    fs::create_directories(out.parent_path(), ec);
    if (ec) throw InputError(o.out, "cannot create its folder: " + ec.message());
  }
  const auto start = std::chrono::steady_clock::now();
  const std::vector<cv::Mat> descriptors = DescriptorCollector(o, logger).collect();
  const double extract_s = seconds_since(start);
  const auto train_start = std::chrono::steady_clock::now();
  const slam::Vocabulary vocabulary = trainer.train(descriptors);
  const double train_s = seconds_since(train_start);
  vocabulary.save(out);
  char line[256];
  std::snprintf(line, sizeof line, "extraction %.1f s, training %.1f s", extract_s, train_s);
  std::cout << "wrote " << o.out << ": k " << vocabulary.branching() << ", L " << vocabulary.depth_levels() << ", "
            << vocabulary.nodes() << " nodes, " << vocabulary.words() << " words from "
            << vocabulary.tree().training_images << " images (" << vocabulary.tree().training_descriptors
            << " descriptors); " << line << "\n";
}

void run_info(const VocabOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const slam::Vocabulary v = slam::Vocabulary::load(o.file);
  const double load_ms = 1e3 * seconds_since(start);
  int min_depth = v.depth_levels(), max_depth = 0;
  for (slam::WordId w = 0; w < v.words(); ++w) {
    min_depth = std::min(min_depth, v.depth(v.word_node(w)));
    max_depth = std::max(max_depth, v.depth(v.word_node(w)));
  }
  const std::uint64_t images = v.tree().training_images;
  const nlohmann::json j = {{"file", o.file},
                            {"k", v.branching()},
                            {"levels", v.depth_levels()},
                            {"nodes", v.nodes()},
                            {"words", v.words()},
                            {"training_images", images},
                            {"training_descriptors", v.tree().training_descriptors},
                            {"leaf_depth_min", min_depth},
                            {"leaf_depth_max", max_depth},
                            {"load_ms", load_ms}};
  if (o.json) {
    std::cout << j.dump(2) << "\n";
    return;
  }
  char ms[32];
  std::snprintf(ms, sizeof ms, "%.1f", load_ms);
  std::cout << "vocabulary:   " << o.file << "\n"
            << "k:            " << v.branching() << "\n"
            << "levels:       " << v.depth_levels() << "\n"
            << "nodes:        " << v.nodes() << "\n"
            << "words:        " << v.words() << " (leaves at depth " << min_depth << ".." << max_depth << ")\n"
            << "images:       " << (images > 0 ? std::to_string(images) : std::string("unknown (DBoW2 text)")) << "\n"
            << "descriptors:  "
            << (v.tree().training_descriptors > 0 ? std::to_string(v.tree().training_descriptors) : std::string("unknown"))
            << "\n"
            << "loaded in:    " << ms << " ms\n";
}

}  // namespace

void add_vocab_command(CLI::App& app, const GlobalOptions& global) {
  CLI::App* vocab = app.add_subcommand("vocab", "Train or inspect a bag-of-words vocabulary for ORB features");
  vocab->require_subcommand(1);
  auto options = std::make_shared<VocabOptions>();

  CLI::App* train = vocab->add_subcommand("train", "Train a vocabulary from the ORB features of images");
  train->add_option("--images", options->image_folders, "Folders of png/jpg images (not recursive)");
  train->add_option("--dataset", options->datasets, "Recorded sequences (TUM RGB-D, EuRoC, TUM-VI): their cam0 images");
  train->add_option("--format", options->format, "Layout of the --dataset sequences (detected when not given)")
      ->transform(dataset_format_check());
  train->add_option("--out", options->out, "Vocabulary file to write (fleetslam binary format)")->required();
  train->add_option("--k", options->k, "Branching factor")->capture_default_str();
  train->add_option("--levels", options->levels, "Depth levels L")->capture_default_str();
  train->add_option("--features", options->features, "ORB features per image")->capture_default_str()->check(CLI::Range(10, 100000));
  train->add_option("--max-images", options->max_images, "Use at most N images: every ceil(total / N)-th (-1: all)");
  train->add_option("--seed", options->seed, "Seed of the k-means++ seeding")->capture_default_str()->check(whole_number_at_least(0));
  train->callback([options, &global] { run_train(*options, global); });

  CLI::App* info = vocab->add_subcommand("info", "k, levels, nodes, words and training images of a vocabulary file");
  info->add_option("file", options->file, "Vocabulary file (fleetslam binary or DBoW2 text)")->required();
  info->add_flag("--json", options->json, "Print JSON instead of text");
  info->callback([options] { run_info(*options); });
}

}  // namespace fleetslam::tools
