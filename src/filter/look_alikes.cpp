#include "tsdf_mcl/filter/look_alikes.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"

namespace tsdf_mcl {

void LookAlikeOptions::validate() const {
  if (!(refute_nats >= 0.0) || !std::isfinite(refute_nats))
    throw Error("converged_look_alike_nats must not be negative");
  if (!(explain_margin >= 0.0 && explain_margin <= 1.0)) throw Error("look-alikes: explain_margin must lie in [0, 1]");
  if (!(proof_window_m > 0.0) || !std::isfinite(proof_window_m))
    throw Error("look-alikes: proof_window_m must be positive");
  if (max_places == 0) throw Error("look-alikes: max_places must be at least 1");
  if (max_refuted == 0) throw Error("look-alikes: max_refuted must be at least 1");
}

LookAlikeMemory::LookAlikeMemory(const TsdfMap& map, const LookAlikeOptions& options, Judge judge, double max_jump_m,
                                 double max_jump_rad)
    : map_(map), options_(options), judge_(std::move(judge)), max_jump_m_(max_jump_m), max_jump_rad_(max_jump_rad) {
  options_.validate();
}

double LookAlikeMemory::Standing::odds_share() const { return 1.0 / (1.0 + std::exp(evidence)); }

double LookAlikeMemory::LookAlike::recent_evidence() const {
  double sum = 0.0;
  for (const auto& scan : recent) sum += scan.second;
  return sum;
}

void LookAlikeMemory::reset() {
  started_ = false;
  travel_ = 0.0;
  proven_.reset();
  track_ = Pose::Identity();
  look_alikes_.clear();
  refuted_.clear();
}

std::vector<Pose> LookAlikeMemory::places() const {
  std::vector<Pose> out;
  for (const LookAlike& l : look_alikes_) out.push_back(l.relative * track_);
  return out;
}

std::vector<LookAlikeMemory::Standing> LookAlikeMemory::kept() const {
  std::vector<Standing> out;
  for (const LookAlike& l : look_alikes_)
    out.push_back(Standing{l.relative * track_, l.evidence, travel_ - l.found_at});
  return out;
}

bool LookAlikeMemory::near(const Pose& a, const Pose& b) const {
  return (a.translation() - b.translation()).norm() <= max_jump_m_ &&
         rotation_angle_between(a.linear(), b.linear()) <= max_jump_rad_;
}

void LookAlikeMemory::refute(const Pose& relative) {
  refuted_.push_back(relative);
  if (refuted_.size() > options_.max_refuted) refuted_.erase(refuted_.begin());
}

std::size_t LookAlikeMemory::update(const Pose& top, const Pose& motion, const std::vector<Pose>& belief,
                                    const std::vector<Eigen::Vector3f>& points, bool track_mapped) {
  proven_.reset();
  if (!enabled()) return 0;
  std::vector<Pose> others = belief;
  std::optional<std::size_t> left;  // index in `others` of the place the track left, if it jumped
  if (started_) {
    const Pose predicted = track_ * motion;
    if (!near(predicted, top)) {
      // The track jumped to another place: the look-alikes and refuted places stay where the odometry carries them,
      // each kept relative to the new track.
      const Pose back = predicted * top.inverse();
      for (LookAlike& l : look_alikes_) l.relative = l.relative * back;
      for (Pose& r : refuted_) r = r * back;
      // The place it left is judged like the belief's others (the belief may have dropped it already).
      left = others.size();
      others.push_back(refine_pose(map_, predicted, points));
    }
  }
  if (started_) travel_ += motion.translation().norm();
  started_ = true;
  track_ = top;

  // The kept look-alikes refined from where the track carries them, then every place judged: the kept ones and the
  // belief's others (independent: the map is read-only; the first judged alone, so that the judge's work on the track
  // is done once).
  const std::size_t kept_count = look_alikes_.size();
  std::vector<Pose> places(kept_count);
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(kept_count); ++i) {
    const auto k = static_cast<std::size_t>(i);
    places[k] = refine_pose(map_, look_alikes_[k].relative * top, points);
  }
  places.insert(places.end(), others.begin(), others.end());
  std::vector<Verdict> verdicts(places.size());
  if (!places.empty()) verdicts[0] = judge_(top, places[0], points);
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t i = 1; i < static_cast<std::ptrdiff_t>(places.size()); ++i) {
    const auto k = static_cast<std::size_t>(i);
    verdicts[k] = judge_(top, places[k], points);
  }
  const auto plausible = [&](const Verdict& v) {
    return v.place_explained >= v.track_explained - options_.explain_margin;
  };

  // Each kept look-alike at its refined place or at the belief's hypothesis there if that fits better (a hypothesis of
  // a spread belief may sit off its place), its evidence summed.
  std::vector<LookAlike> kept;
  double inherited = 0.0;  // for the place the track left: the evidence of the look-alike it moved to, turned round
  for (std::size_t k = 0; k < kept_count; ++k) {
    LookAlike l = look_alikes_[k];
    Pose place = places[k];
    Verdict verdict = verdicts[k];
    for (std::size_t j = kept_count; j < places.size(); ++j) {
      if (near(places[j], place) && verdicts[j].evidence < verdict.evidence) {
        place = places[j];
        verdict = verdicts[j];
      }
    }
    if (near(place, top)) {  // it became the track
      if (left) inherited = -l.evidence;
      continue;
    }
    const auto same = [&](const LookAlike& x) { return near(x.relative * top, place); };
    if (std::any_of(kept.begin(), kept.end(), same)) continue;
    l.relative = place * top.inverse();
    if (left) {
      // Its evidence so far was against the place the track left: against the new track it starts over (summed
      // against a global search's wrong modes, it proved the mirror wing better than the right track, which the
      // search had just found).
      l.evidence = 0.0;
      l.recent.clear();
      l.found_at = travel_;
    }
    l.evidence += verdict.evidence;
    l.recent.emplace_back(travel_, verdict.evidence);
    while (travel_ - l.recent.front().first > options_.proof_window_m) l.recent.pop_front();
    // Proven while the sum since it was found and the sum over the window both hold refute_nats against the track,
    // the track's scan judged by the map.
    if (track_mapped && l.evidence <= -options_.refute_nats && l.recent_evidence() <= -options_.refute_nats &&
        plausible(verdict) && (!proven_ || l.evidence < proven_->evidence)) {
      proven_ = Standing{place, l.evidence, travel_ - l.found_at};
    }
    if (l.evidence >= options_.refute_nats || !plausible(verdict)) {
      refute(l.relative);
      continue;
    }
    kept.push_back(l);
  }
  look_alikes_ = std::move(kept);

  // New look-alikes among the belief's other places: any this scan does not refute by itself. A place the scans
  // refuted before stays refuted when the search finds it again (the mirror wing after the cabinet: found again, it
  // starts with a tiny share, which no measure taken since tells from a fresh twin's), unless this scan alone favours
  // it as much.
  // The place the track left, and any of the belief's places there (a hypothesis the belief still holds at it comes
  // first), inherit the evidence of the look-alike the track moved to.
  const std::optional<Pose> left_place = left ? std::optional<Pose>(places[kept_count + *left]) : std::optional<Pose>();
  for (std::size_t j = kept_count; j < places.size(); ++j) {
    if (look_alikes_.size() >= options_.max_places) break;
    const Pose& o = places[j];
    if (near(o, top)) continue;
    const auto known = [&](const Pose& relative) { return near(relative * top, o); };
    if (std::any_of(look_alikes_.begin(), look_alikes_.end(), [&](const LookAlike& l) { return known(l.relative); }))
      continue;
    const bool refuted = std::any_of(refuted_.begin(), refuted_.end(), known);
    const Verdict& now = verdicts[j];
    const bool from_left = left_place && near(o, *left_place);
    const double evidence = now.evidence + (from_left ? inherited : 0.0);
    if (evidence >= options_.refute_nats) {
      if (from_left && plausible(now) && !refuted) refute(o * top.inverse());  // the proven one's rival
      continue;
    }
    if (!plausible(now)) continue;
    if (refuted && now.evidence > -options_.refute_nats) continue;
    look_alikes_.push_back(LookAlike{o * top.inverse(), evidence, {{travel_, now.evidence}}, travel_});
  }
  return look_alikes_.size();
}

}  // namespace tsdf_mcl
