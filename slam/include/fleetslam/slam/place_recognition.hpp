#pragma once
// Place recognition settings shared by loop closing and relocalisation: which vocabulary the agent
// loads, and how keyframes and frames are turned into bag-of-words vectors (vocabulary.hpp) for the
// keyframe database (keyframe_database.hpp) and BoW-guided matching (matcher.hpp, search_by_bow).

#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {

struct PlaceRecognitionConfig {
  bool enabled = true;
  // Vocabulary file; empty: the project's default vocabulary (default_vocabulary_path()).
  std::string vocabulary;
  // Direct index depth: features are grouped by their node this many levels above the leaves.
  int levels_up = 2;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("vocabulary", vocabulary);
    v("levels_up", levels_up, core::Limits<int>{0, 10});
  }
};

// The shipped default vocabulary (data/vocabulary/orb_default.fsvoc), as the build configured it.
std::filesystem::path default_vocabulary_path();

// Loads config.vocabulary, or the default file when it is empty. Throws InputError
// ("place_recognition.vocabulary", why) when the file is missing, and the vocabulary's own InputError
// when it is unreadable or foreign.
std::shared_ptr<const Vocabulary> load_place_vocabulary(const PlaceRecognitionConfig& config);

}  // namespace fleetslam::slam
