#include "tsdf_mcl/io/bag_messages.hpp"

#include <cmath>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::msg {

Header stamp_of(double seconds) {
  // ros::Time::fromSec: the whole seconds, the rest rounded to nanoseconds, a carry where that rounds up to 1 s.
  Header h;
  h.sec = static_cast<std::int64_t>(std::floor(seconds));
  const auto nsec = static_cast<std::uint64_t>(std::round((seconds - static_cast<double>(h.sec)) * 1e9));
  h.sec += static_cast<std::int64_t>(nsec / 1000000000u);
  h.nsec = static_cast<std::uint32_t>(nsec % 1000000000u);
  return h;
}

double finite(double value, const std::string& what, const char* item) {
  if (!std::isfinite(value)) throw Error(what + ": " + item + " is not a finite number");
  return value;
}

Eigen::Quaterniond unit_quaternion(double x, double y, double z, double w, const std::string& what, const char* item) {
  const Eigen::Quaterniond q(w, x, y, z);
  if (std::abs(q.norm() - 1.0) > 1e-2) {
    throw Error(what + ": " + item + " (" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) +
                ", " + std::to_string(w) + ") is not a unit quaternion");
  }
  return q.normalized();
}

Pose pose_of(const Eigen::Vector3d& translation, const Eigen::Quaterniond& rotation) {
  Pose p = Pose::Identity();
  p.linear() = rotation.toRotationMatrix();
  p.translation() = translation;
  return p;
}

}  // namespace tsdf_mcl::msg
