#pragma once
// The last converged pose in a small file, so that a localizer restarted where it stopped (a robot switched off and
// on) starts there instead of searching the whole map, as nav2 AMCL users expect of its saved pose. The ROS nodes
// keep one by default, `tsdf-mcl localize --last_pose_file FILE` on request. The file names the map it belongs to
// by the map's geometry (voxel size, box, blocks), so a file written on another map is stale; a stale file, a pose
// off the map or a corrupt file is one warning, and the localizer searches globally.
//
//   LastPoseFile last(path, map);
//   options.initial_pose = last.start(options, &note, &warning);  // the kept pose, unless options has one
//   Localizer localizer(map, options);
//   for (each scan) note(last.follow(localizer, localizer.process(...)));   // keeps converged poses, once a second
//   last.flush();                                              // the newest converged pose, when the run ends
#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

class LastPoseFile {
 public:
  static constexpr double kMinIntervalSeconds = 1.0;

  // `map` must outlive this object.
  LastPoseFile(std::filesystem::path file, const TsdfMap& map);

  // The kept pose, or nullopt: without a file (`warning` left empty), or with one that is corrupt, written on another
  // map or off this one (`warning` says which, in one line).
  std::optional<Pose> load(std::string* warning) const;
  // Keeps `pose` (stamped `time`, s) unless the last write was less than kMinIntervalSeconds ago (wall time); the
  // file is replaced atomically. Returns whether it wrote. Throws Error naming the file where it cannot be written.
  bool keep(const Pose& pose, double time);
  // Keeps `pose` now, whenever the last write was.
  void keep_now(const Pose& pose, double time);

  // The pose a localizer with `options` starts from: the kept one, unless `options` has an initial pose of its own
  // or the file holds none that can be used. `note` says where it starts, `warning` why a file is not used.
  std::optional<Pose> start(const LocalizerOptions& options, std::string* note, std::string* warning);
  // After each scan of a localizer started at start()'s pose: if its first update finds the scan does not fit there
  // (initial_pose_misfit), the localizer searches the whole map from the next scan and the returned line says so;
  // a converged estimate is kept (keep). Throws Error where the file cannot be written.
  std::string follow(Localizer& localizer, const ScanRecord& record);
  // The localizer no longer starts from the kept pose (an operator's pose, a global search requested, a restart).
  void forget_start() { started_at_.reset(); }
  // Keeps the newest converged estimate that keep() held back (a run or node that ends keeps where it stopped).
  void flush();

  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
  const TsdfMap& map_;
  std::string map_id_;
  std::optional<std::chrono::steady_clock::time_point> last_write_;
  std::optional<Pose> started_at_;
  std::optional<std::pair<Pose, double>> held_back_;
};

// Why the first filter update after starting at `initial` says the scan does not fit there, or "" when it fits: its
// best place lies more than a metre away (the background search found a better place), or it fits fewer of the
// scan's points than convergence needs (converged_min_inliers).
std::string initial_pose_misfit(const FilterStep& step, const LocalizerOptions& options, const Pose& initial);

}  // namespace tsdf_mcl
