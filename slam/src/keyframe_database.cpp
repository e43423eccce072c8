// Inverted index of keyframe BoW vectors and its scored queries.

#include "fleetslam/slam/keyframe_database.hpp"

#include <algorithm>
#include <utility>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {

void KeyframeDatabase::add(KeyframeId id, const BowVector& bow) {
  for (std::size_t i = 0; i < bow.entries.size(); ++i) {
    FLEETSLAM_CHECK(bow.entries[i].weight > 0.0, "BoW weights must be positive");
    FLEETSLAM_CHECK(i == 0 || bow.entries[i - 1].word < bow.entries[i].word, "BoW words must be ascending and distinct");
  }
  erase(id);
  std::size_t slot = slots_.size();
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slots_.emplace_back();
  }
  slots_[slot] = {id, bow};
  slot_of_[id] = slot;
  for (const BowEntry& e : bow.entries) index_[e.word].push_back({slot, e.weight});
}

bool KeyframeDatabase::erase(KeyframeId id) {
  const auto it = slot_of_.find(id);
  if (it == slot_of_.end()) return false;
  const std::size_t slot = it->second;
  for (const BowEntry& e : slots_[slot].bow.entries) {
    const auto list = index_.find(e.word);
    if (list == index_.end()) continue;
    std::vector<Posting>& postings = list->second;
    postings.erase(std::remove_if(postings.begin(), postings.end(), [&](const Posting& p) { return p.slot == slot; }),
                   postings.end());
    if (postings.empty()) index_.erase(list);
  }
  slots_[slot] = Slot{};
  free_slots_.push_back(slot);
  slot_of_.erase(it);
  return true;
}

void KeyframeDatabase::clear() {
  index_.clear();
  slots_.clear();
  free_slots_.clear();
  slot_of_.clear();
}

const BowVector* KeyframeDatabase::find(KeyframeId id) const {
  const auto it = slot_of_.find(id);
  return it == slot_of_.end() ? nullptr : &slots_[it->second].bow;
}

std::vector<KeyframeId> KeyframeDatabase::keyframes_with(WordId word) const {
  std::vector<KeyframeId> ids;
  const auto list = index_.find(word);
  if (list == index_.end()) return ids;
  for (const Posting& p : list->second) ids.push_back(slots_[p.slot].id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<PlaceCandidate> KeyframeDatabase::query(const BowVector& bow, const PlaceQuery& options) const {
  // Each keyframe's score accumulates min(query, keyframe) over shared words in ascending word order, the
  // sum bow_score forms, so the two agree bit for bit.
  std::vector<double> score(slots_.size(), 0.0);
  std::vector<int> shared(slots_.size(), 0);
  std::vector<std::size_t> touched;
  for (const BowEntry& e : bow.entries) {
    const auto list = index_.find(e.word);
    if (list == index_.end()) continue;
    for (const Posting& p : list->second) {
      if (shared[p.slot]++ == 0) touched.push_back(p.slot);
      score[p.slot] += std::min(e.weight, p.weight);
    }
  }
  std::vector<PlaceCandidate> candidates;
  for (const std::size_t slot : touched) {
    const PlaceCandidate c{slots_[slot].id, std::clamp(score[slot], 0.0, 1.0), shared[slot]};
    if (c.shared_words < options.min_shared_words || c.score < options.min_score || options.exclude.count(c.id) > 0) {
      continue;
    }
    candidates.push_back(c);
  }
  std::sort(candidates.begin(), candidates.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.score != b.score ? a.score > b.score : a.id < b.id;
  });
  if (options.max_results > 0 && candidates.size() > static_cast<std::size_t>(options.max_results)) {
    candidates.resize(static_cast<std::size_t>(options.max_results));
  }
  return candidates;
}

}  // namespace fleetslam::slam
