// The agent's vocabulary: configured file or the shipped default.

#include "fleetslam/slam/place_recognition.hpp"

#include <system_error>

#include "fleetslam/core/error.hpp"

#ifndef FLEETSLAM_DEFAULT_VOCABULARY
#error "FLEETSLAM_DEFAULT_VOCABULARY must be defined by slam/CMakeLists.txt"
#endif

namespace fleetslam::slam {

std::filesystem::path default_vocabulary_path() { return std::filesystem::path(FLEETSLAM_DEFAULT_VOCABULARY); }

std::shared_ptr<const Vocabulary> load_place_vocabulary(const PlaceRecognitionConfig& config) {
  const std::filesystem::path file = config.vocabulary.empty() ? default_vocabulary_path()
                                                               : std::filesystem::path(config.vocabulary);
  std::error_code error;
  if (!std::filesystem::is_regular_file(file, error)) {
    throw InputError("place_recognition.vocabulary",
                     "vocabulary file " + file.string() + " not found" +
                         (config.vocabulary.empty() ? " (the default; set place_recognition.vocabulary)" : ""));
  }
  return std::make_shared<const Vocabulary>(Vocabulary::load(file));
}

}  // namespace fleetslam::slam
