#include "tsdf_mcl/localizer/last_pose_file.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"

namespace tsdf_mcl {
namespace {

constexpr const char* kFormat = "tsdf-mcl last pose 1";
// An estimate this far (m) from the initial pose after the first update did not come from there.
constexpr double kMovedAway = 1.0;
// A pose farther than this (m) outside the map's box is not on it.
constexpr double kMapMargin = 1.0;
// A file this large is not one of ours.
constexpr std::uintmax_t kMaxFileBytes = 4096;

// What identifies a map: its geometry and allocated blocks (a map rebuilt from other scans differs in them).
std::string map_identity(const TsdfMap& map) {
  const Eigen::Vector3i& b = map.min_block();
  const Eigen::Vector3i& d = map.dims_blocks();
  char buf[200];
  std::snprintf(buf, sizeof(buf), "voxel %.6g m, truncation %.6g m, blocks %d %d %d + %d %d %d, %zu allocated",
                static_cast<double>(map.voxel_size()), static_cast<double>(map.truncation()), b.x(), b.y(), b.z(),
                d.x(), d.y(), d.z(), map.block_count());
  return buf;
}

}  // namespace

LastPoseFile::LastPoseFile(std::filesystem::path file, const TsdfMap& map)
    : file_(std::move(file)), map_(map), map_id_(map_identity(map)) {}

std::optional<Pose> LastPoseFile::load(std::string* warning) const {
  std::error_code ec;
  if (!std::filesystem::exists(file_, ec)) return std::nullopt;
  const std::string name = "last pose file " + one_line(file_.string());
  const auto fail = [&](const std::string& why) -> std::optional<Pose> {
    if (warning) *warning = name + " not used: " + why + "; searching the whole map";
    return std::nullopt;
  };
  if (!std::filesystem::is_regular_file(file_, ec)) return fail("not a regular file");
  if (std::filesystem::file_size(file_, ec) > kMaxFileBytes) return fail("larger than a pose file is");
  std::ifstream in(file_);
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || j.value("format", "") != kFormat) return fail("not a pose file of this version (corrupt?)");
  if (j.value("map", "") != map_id_) return fail("written on another map (" + one_line(j.value("map", "")) + ")");
  double v[7];
  const char* keys[] = {"x", "y", "z", "qx", "qy", "qz", "qw"};
  for (int i = 0; i < 7; ++i) {
    if (!j.contains(keys[i]) || !j[keys[i]].is_number()) return fail(std::string("no number '") + keys[i] + "'");
    v[i] = j[keys[i]].get<double>();
    if (!std::isfinite(v[i])) return fail(std::string("'") + keys[i] + "' is not finite");
  }
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (std::abs(q.norm() - 1.0) > 1e-3) return fail("its quaternion is not of unit length");
  const Eigen::Vector3d t(v[0], v[1], v[2]);
  const Eigen::Vector3d lo = map_.world_min().cast<double>() - Eigen::Vector3d::Constant(kMapMargin);
  const Eigen::Vector3d hi = map_.world_max().cast<double>() + Eigen::Vector3d::Constant(kMapMargin);
  if (!((t.array() >= lo.array()).all() && (t.array() <= hi.array()).all())) return fail("its pose lies off the map");
  Pose pose = Pose::Identity();
  pose.linear() = q.normalized().toRotationMatrix();
  pose.translation() = t;
  return pose;
}

bool LastPoseFile::keep(const Pose& pose, double time) {
  const auto now = std::chrono::steady_clock::now();
  if (last_write_ && now - *last_write_ < std::chrono::duration<double>(kMinIntervalSeconds)) return false;
  keep_now(pose, time);
  return true;
}

void LastPoseFile::keep_now(const Pose& pose, double time) {
  last_write_ = std::chrono::steady_clock::now();
  const Eigen::Quaterniond q(pose.rotation());
  const Eigen::Vector3d t = pose.translation();
  const nlohmann::json j = {{"format", kFormat}, {"map", map_id_}, {"time", time}, {"x", t.x()},  {"y", t.y()},
                            {"z", t.z()},        {"qx", q.x()},    {"qy", q.y()},  {"qz", q.z()}, {"qw", q.w()}};
  write_file_atomically(file_, j.dump(1) + "\n", "last pose file");
}

std::optional<Pose> LastPoseFile::start(const LocalizerOptions& options, std::string* note, std::string* warning) {
  started_at_.reset();
  if (options.initial_pose) return std::nullopt;
  started_at_ = load(warning);
  if (started_at_) {
    const Eigen::Vector3d t = started_at_->translation();
    const Eigen::Vector3d x = started_at_->rotation().col(0);
    char buf[160];
    std::snprintf(buf, sizeof(buf), "starting at the last converged pose (%.2f, %.2f, %.2f, yaw %.1f deg) from ", t.x(),
                  t.y(), t.z(), std::atan2(x.y(), x.x()) * 180.0 / M_PI);
    *note = buf + one_line(file_.string());
  }
  return started_at_;
}

std::string LastPoseFile::follow(Localizer& localizer, const ScanRecord& record) {
  if (started_at_ && record.step.updated) {
    const std::string misfit = initial_pose_misfit(record.step, localizer.options(), *started_at_);
    started_at_.reset();
    if (!misfit.empty()) {
      localizer.reset_global();
      return "the first scan does not fit at the last converged pose: " + misfit +
             "; searching the whole map from the next scan";
    }
  }
  if (record.step.state != TrackState::kConverged) return "";
  held_back_.reset();
  if (!keep(record.step.estimate.pose, record.time))
    held_back_ = std::make_pair(record.step.estimate.pose, record.time);
  return "";
}

void LastPoseFile::flush() {
  if (!held_back_) return;
  keep_now(held_back_->first, held_back_->second);
  held_back_.reset();
}

std::string initial_pose_misfit(const FilterStep& step, const LocalizerOptions& options, const Pose& initial) {
  char buf[300];
  const double moved = (step.estimate.pose.translation() - initial.translation()).norm();
  if (moved > kMovedAway) {
    std::snprintf(buf, sizeof(buf), "the best place after the first update lies %.1f m from it", moved);
    return buf;
  }
  const double fit = step.estimate.inlier_ratio;
  const double needed = options.filter.states.min_inliers;
  if (std::isfinite(fit) && fit < needed) {
    std::snprintf(buf, sizeof(buf), "%.0f %% of its points lie within %.2f m of a surface (converged needs %.0f %%)",
                  100.0 * fit, static_cast<double>(options.filter.places.inlier_distance), 100.0 * needed);
    return buf;
  }
  return "";
}

}  // namespace tsdf_mcl
