#include "tsdf_mcl/filter/place_ledger.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {

void LedgerOptions::validate() const {
  if (!(decide_nats >= 0.0) || !std::isfinite(decide_nats)) throw Error("evidence_nats must not be negative");
  if (!(window_m > 0.0) || !std::isfinite(window_m)) throw Error("proof_travel must be positive (m)");
  if (!(explain_margin >= 0.0 && explain_margin <= 1.0)) throw Error("ledger: explain_margin must lie in [0, 1]");
  if (max_rivals == 0) throw Error("ledger: max_rivals must be at least 1");
  if (max_refuted == 0) throw Error("ledger: max_refuted must be at least 1");
}

double PlaceLedger::Standing::odds_share() const { return 1.0 / (1.0 + std::exp(evidence)); }

double PlaceLedger::Rival::window() const {
  double sum = 0.0;
  for (const auto& scan : recent) sum += scan.second;
  return sum;
}

PlaceLedger::PlaceLedger(const LedgerOptions& options, const SamePlace& same_place, Judge judge, Refine refine)
    : options_(options), same_place_(same_place), judge_(std::move(judge)), refine_(std::move(refine)) {
  options_.validate();
  same_place_.validate();
}

void PlaceLedger::reset() {
  started_ = false;
  track_ = Pose::Identity();
  travel_ = 0.0;
  judged_travel_ = 0.0;
  failing_ = 0;
  rivals_.clear();
  refuted_.clear();
}

PlaceLedger::Standing PlaceLedger::standing(const Rival& r) const {
  Standing s;
  s.place = r.relative * track_;
  s.evidence = r.evidence;
  s.travelled = travel_ - r.found_at;
  s.proven = proven(r);
  return s;
}

bool PlaceLedger::proven(const Rival& r) const {
  return r.evidence <= -options_.decide_nats && r.window() <= -options_.decide_nats &&
         travel_ - r.found_at >= options_.window_m;
}

bool PlaceLedger::plausible(const Verdict& v) const {
  return v.place_explained >= v.track_explained - options_.explain_margin;
}

double PlaceLedger::counted(double evidence, bool track_mapped) const {
  return track_mapped ? evidence : std::max(evidence, 0.0);
}

void PlaceLedger::refute(const Pose& relative) {
  refuted_.push_back(relative);
  if (refuted_.size() > options_.max_refuted) refuted_.erase(refuted_.begin());
}

void PlaceLedger::rebase(const Pose& predicted, const Pose& track) {
  const Pose back = predicted * track.inverse();
  for (Rival& r : rivals_) r.relative = r.relative * back;
  for (Pose& r : refuted_) r = r * back;
}

std::optional<std::size_t> PlaceLedger::rival_at(const Pose& place) const {
  for (std::size_t k = 0; k < rivals_.size(); ++k) {
    if (same_place_(rivals_[k].relative * track_, place)) return k;
  }
  return std::nullopt;
}

PlaceLedger::Outcome PlaceLedger::update(const Input& in) {
  Outcome out;
  out.track = in.track;
  const Pose predicted = track_ * in.motion;
  const bool moved = started_ && !same_place_(predicted, in.track);
  out.moved = moved;
  if (!enabled()) {
    track_ = in.challenger ? *in.challenger : in.track;
    out.track = track_;
    out.moved = moved || in.challenger.has_value();
    out.challenger_taken = in.challenger.has_value();
    started_ = true;
    return out;
  }
  std::optional<Pose> left;
  if (started_) {
    travel_ += in.motion.translation().norm();
    if (in.track_mapped) judged_travel_ += in.motion.translation().norm();
    if (moved) {
      rebase(predicted, in.track);
      left = refine_(predicted);
    }
  }
  started_ = true;
  track_ = in.track;

  // The followed rivals refined from where the track carries them, then every place judged against the track.
  const std::size_t followed = rivals_.size();
  std::vector<Pose> places(followed);
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(followed); ++i) {
    const auto k = static_cast<std::size_t>(i);
    places[k] = refine_(rivals_[k].relative * track_);
  }
  if (in.challenger) places.push_back(*in.challenger);
  places.insert(places.end(), in.others.begin(), in.others.end());
  std::optional<std::size_t> left_index;
  if (left) {
    left_index = places.size();
    places.push_back(*left);
  }
  const std::vector<Verdict> verdicts = judge_all(places);
  double inherited = 0.0;
  follow_rivals(places, verdicts, followed, moved, in.track_mapped, inherited);
  admit(places, verdicts, followed, left_index, inherited, in.track_mapped);
  if (in.challenger) {
    challenge(in, in.track, out);
  } else {
    failing_ = 0;
  }
  out.track = track_;
  for (const Rival& r : rivals_) {
    const Standing s = standing(r);
    if (in.challenger && !out.challenger_taken && same_place_(s.place, *in.challenger)) continue;
    if (s.proven && (!out.proven || s.evidence < out.proven->evidence)) out.proven = s;
    out.rivals.push_back(s);
  }
  return out;
}

std::vector<PlaceLedger::Verdict> PlaceLedger::judge_all(const std::vector<Pose>& places) const {
  // The first alone, so that the judge's work on the track side is done once before the others run in parallel.
  std::vector<Verdict> verdicts(places.size());
  if (!places.empty()) verdicts[0] = judge_(track_, places[0]);
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t i = 1; i < static_cast<std::ptrdiff_t>(places.size()); ++i) {
    const auto k = static_cast<std::size_t>(i);
    verdicts[k] = judge_(track_, places[k]);
  }
  return verdicts;
}

void PlaceLedger::follow_rivals(const std::vector<Pose>& places, const std::vector<Verdict>& verdicts,
                                std::size_t followed, bool moved, bool track_mapped, double& inherited) {
  std::vector<Rival> kept;
  for (std::size_t k = 0; k < followed; ++k) {
    Rival r = rivals_[k];
    Pose place = places[k];
    Verdict verdict = verdicts[k];
    // At the belief's place there instead where that fits better for the rival (a spread mode's mean sits off its
    // place).
    for (std::size_t j = followed; j < places.size(); ++j) {
      if (same_place_(places[j], place) && verdicts[j].evidence < verdict.evidence) {
        place = places[j];
        verdict = verdicts[j];
      }
    }
    if (same_place_(place, track_)) {  // the track moved onto it
      if (moved) inherited = -r.evidence;
      continue;
    }
    const auto same = [&](const Rival& x) { return same_place_(x.relative * track_, place); };
    if (std::any_of(kept.begin(), kept.end(), same)) continue;
    r.relative = place * track_.inverse();
    if (moved) {  // its ratio so far was against the place the track left
      r.evidence = 0.0;
      r.recent.clear();
      r.found_at = travel_;
    }
    const double e = counted(verdict.evidence, track_mapped);
    r.evidence += e;
    // The window holds the last window_m of travel where the map judged the track: a track carried off the map (a
    // kidnapping, an unmapped room) keeps the evidence it gathered while it could be judged.
    if (track_mapped) {
      r.recent.emplace_back(judged_travel_, e);
      while (judged_travel_ - r.recent.front().first > options_.window_m) r.recent.pop_front();
    }
    if (r.evidence >= options_.decide_nats || !plausible(verdict)) {
      refute(r.relative);
      continue;
    }
    kept.push_back(std::move(r));
  }
  rivals_ = std::move(kept);
}

void PlaceLedger::admit(const std::vector<Pose>& places, const std::vector<Verdict>& verdicts, std::size_t followed,
                        std::optional<std::size_t> left, double inherited, bool track_mapped) {
  // A refuted place stays refuted when the search finds it again (found again, it starts with a tiny share, which no
  // measure taken since tells from a fresh twin's), unless this scan alone favours it by decide_nats. The place the
  // track left inherits the ratio of the rival the track moved onto, turned round.
  for (std::size_t j = followed; j < places.size(); ++j) {
    if (rivals_.size() >= options_.max_rivals) break;
    const Pose& place = places[j];
    if (same_place_(place, track_) || rival_at(place)) continue;
    const auto known = [&](const Pose& relative) { return same_place_(relative * track_, place); };
    const bool refuted = std::any_of(refuted_.begin(), refuted_.end(), known);
    const Verdict& now = verdicts[j];
    // The place the track left, and any of the belief's places there (the belief may still hold some of it).
    const bool from_left = left && same_place_(place, places[*left]);
    const double e = counted(now.evidence, track_mapped);
    const double evidence = e + (from_left ? inherited : 0.0);
    if (evidence >= options_.decide_nats) {
      if (from_left && plausible(now) && !refuted) refute(place * track_.inverse());
      continue;
    }
    if (!plausible(now)) continue;
    if (refuted && now.evidence > -options_.decide_nats) continue;
    rivals_.push_back(Rival{place * track_.inverse(), evidence, {{judged_travel_, e}}, travel_});
  }
}

void PlaceLedger::challenge(const Input& in, const Pose& continuation, Outcome& out) {
  const std::optional<std::size_t> k = rival_at(*in.challenger);
  failing_ = in.track_implausible ? failing_ + 1 : 0;
  if ((k && proven(rivals_[*k])) || failing_ >= 2) {
    // Taken: the challenger becomes the track, the track it left a rival with the ratio turned round.
    const double ratio = k ? rivals_[*k].evidence : 0.0;
    if (k) rivals_.erase(rivals_.begin() + static_cast<std::ptrdiff_t>(*k));
    rebase(continuation, *in.challenger);
    track_ = *in.challenger;
    for (Rival& r : rivals_) {  // evidence against the old track says nothing against the new one
      r.evidence = 0.0;
      r.recent.clear();
      r.found_at = travel_;
    }
    if (rivals_.size() < options_.max_rivals && -ratio < options_.decide_nats)
      rivals_.push_back(Rival{continuation * track_.inverse(), -ratio, {{judged_travel_, -ratio}}, travel_});
    failing_ = 0;
    out.moved = out.challenger_taken = true;
    return;
  }
  if (!k) {
    out.challenger_refuted = true;
    return;
  }
  out.holding = true;
  out.challenge = rivals_[*k].evidence;
  out.challenge_travel = travel_ - rivals_[*k].found_at;
}

}  // namespace tsdf_mcl
