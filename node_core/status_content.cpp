#include "status_content.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "text_format.hpp"

namespace tsdf_mcl::node {
namespace {

double yaw_deg(const Pose& p) {
  const Eigen::Vector3d x = p.rotation().col(0);
  return std::atan2(x.y(), x.x()) * 180.0 / M_PI;
}

double best_share(const FilterStep& step) {
  return step.estimate.places.empty() ? 0.0 : step.estimate.places.front().weight;
}

}  // namespace

std::array<double, 36> fixed_frame_covariance(const Pose& mean, const Matrix6d& body_covariance) {
  // A small rotation δ about the body axes is R·δ about the fixed axes: rotate the rotation rows and columns.
  Matrix6d j = Matrix6d::Identity();
  j.bottomRightCorner<3, 3>() = mean.rotation();
  const Matrix6d world = j * body_covariance * j.transpose();
  std::array<double, 36> out{};
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) out[static_cast<std::size_t>(r * 6 + c)] = world(r, c);
  return out;
}

PosesOut decimated_particles(const ParticleSnapshot& snapshot, std::size_t max_particles, Stamp stamp,
                             const std::string& frame_id) {
  PosesOut out;
  out.stamp = stamp;
  out.frame_id = frame_id;
  const std::size_t n = snapshot.particles.size();
  const std::size_t every = std::max<std::size_t>(1, (n + max_particles - 1) / std::max<std::size_t>(1, max_particles));
  for (std::size_t i = 0; i < n; i += every) {
    const ParticleSnapshot::Particle& p = snapshot.particles[i];
    Pose pose = Pose::Identity();
    pose.linear() = p.orientation.cast<double>().normalized().toRotationMatrix();
    pose.translation() = p.position.cast<double>();
    out.poses.push_back(pose);
    out.weights.push_back(p.weight);
  }
  return out;
}

std::string places_text(const std::vector<Place>& places) {
  std::string text;
  for (std::size_t i = 0; i < places.size() && i < 5; ++i) {
    const Place& h = places[i];
    const Eigen::Vector3d t = h.pose.translation();
    text += format("%s%.0f %% at (%.2f, %.2f, %.2f, yaw %.0f deg)", i ? "; " : "", 100.0 * h.weight, t.x(), t.y(),
                   t.z(), yaw_deg(h.pose));
  }
  return text;
}

std::string positions_text(const std::vector<Pose>& places) {
  std::string text;
  for (const Pose& p : places) {
    text += format("%s(%.2f, %.2f, %.2f)", text.empty() ? "" : "; ", p.translation().x(), p.translation().y(),
                   p.translation().z());
  }
  return text;
}

std::string state_reason(const FilterStep& step) {
  // The filter's reason (track_state.hpp), then the numbers it decided on.
  const PoseEstimate& e = step.estimate;
  std::string text = to_string(step.reason);
  if (!step.rivals.empty()) text += format(" (%zu followed)", step.rivals.size());
  text += format("; %zu place%s, the best holds %.0f %% of the belief", e.places.size(),
                 e.places.size() == 1 ? "" : "s", 100.0 * best_share(step));
  // No fit before the first update.
  if (std::isfinite(e.inlier_ratio) && std::isfinite(e.coverage)) {
    text += format("; %.0f %% of the scan fits, the map covers %.0f %%", 100.0 * e.inlier_ratio, 100.0 * e.coverage);
  }
  return text;
}

}  // namespace tsdf_mcl::node
