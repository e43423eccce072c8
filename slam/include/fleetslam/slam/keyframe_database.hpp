#pragma once
// Keyframes indexed by their bag-of-words vectors for place recognition (loop closing, relocalisation,
// map merging): an inverted index word -> (keyframe, weight), so that a query only visits keyframes that
// share a word with it (DBoW2 paper, section V-A). Scores are Vocabulary's L1 score, bit-identical to
// bow_score(query, keyframe's vector). Not thread-safe: its owner serialises access, as for the Map.

#include <cstddef>
#include <map>
#include <set>
#include <unordered_map>
#include <vector>

#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {

struct PlaceQuery {
  int max_results = 10;               // best N candidates; <= 0: all that pass
  double min_score = 0.0;             // candidates scoring below this are left out
  int min_shared_words = 1;           // and those sharing fewer words with the query
  std::set<KeyframeId> exclude;       // never returned (the querying keyframe, its covisible neighbours)
};

struct PlaceCandidate {
  KeyframeId id = -1;
  double score = 0.0;     // bow_score(query, keyframe) in [0, 1]
  int shared_words = 0;
  bool operator==(const PlaceCandidate& o) const {
    return id == o.id && score == o.score && shared_words == o.shared_words;
  }
};

class KeyframeDatabase {
 public:
  KeyframeDatabase() = default;

  // Indexes a keyframe's vector (replacing what it had when already present). The vector must be as
  // Vocabulary makes them: ascending distinct words with positive weights (checked: InvariantError).
  void add(KeyframeId id, const BowVector& bow);
  // Removes a keyframe; false when it was not there.
  bool erase(KeyframeId id);
  void clear();

  bool contains(KeyframeId id) const { return slot_of_.count(id) > 0; }
  std::size_t size() const { return slot_of_.size(); }
  // The indexed vector of a keyframe, nullptr when absent.
  const BowVector* find(KeyframeId id) const;
  // Keyframes indexed under a word (ascending ids).
  std::vector<KeyframeId> keyframes_with(WordId word) const;

  // Candidates sharing words with `bow`, by decreasing score, equal scores by increasing id.
  std::vector<PlaceCandidate> query(const BowVector& bow, const PlaceQuery& options = PlaceQuery{}) const;

 private:
  struct Posting {
    std::size_t slot = 0;
    double weight = 0.0;
  };
  struct Slot {
    KeyframeId id = -1;
    BowVector bow;
  };

  std::unordered_map<WordId, std::vector<Posting>> index_;
  std::vector<Slot> slots_;
  std::vector<std::size_t> free_slots_;
  std::map<KeyframeId, std::size_t> slot_of_;
};

}  // namespace fleetslam::slam
