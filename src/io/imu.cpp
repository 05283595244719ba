#include "tsdf_mcl/io/imu.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {

std::vector<ImuSample> read_imu(const std::filesystem::path& file) {
  std::istringstream in(read_input_file(file, "IMU", limits::kMaxTextFileBytes));
  std::vector<ImuSample> samples;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::vector<double> v;
    std::string word;
    while (fields >> word) {
      char* end = nullptr;
      const double d = std::strtod(word.c_str(), &end);
      if (end == word.c_str() || *end != '\0' || !std::isfinite(d)) {
        throw Error(file.string() + ":" + std::to_string(number) + ": '" + word + "' is not a finite number");
      }
      v.push_back(d);
    }
    if (v.empty()) continue;
    if (v.size() != 4 && v.size() != 7) {
      throw Error(file.string() + ":" + std::to_string(number) + ": expected t ax ay az [wx wy wz], got " +
                  std::to_string(v.size()) + " numbers");
    }
    if (!samples.empty() && v[0] < samples.back().time) {
      throw Error(file.string() + ":" + std::to_string(number) + ": time goes backwards");
    }
    samples.push_back({v[0], Eigen::Vector3d(v[1], v[2], v[3])});
  }
  if (samples.empty()) throw Error(file.string() + ": no samples");
  return samples;
}

std::optional<Eigen::Vector3f> imu_up_at(const std::vector<ImuSample>& samples, double time, double window) {
  const auto first = std::lower_bound(samples.begin(), samples.end(), time - window,
                                      [](const ImuSample& s, double t) { return s.time < t; });
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t count = 0;
  for (auto it = first; it != samples.end() && it->time <= time + window; ++it) {
    sum += it->acceleration;
    ++count;
  }
  if (count == 0) return std::nullopt;
  const Eigen::Vector3d mean = sum / static_cast<double>(count);
  constexpr double kGravity = 9.81;
  if (std::abs(mean.norm() - kGravity) > 0.3 * kGravity) return std::nullopt;
  return mean.normalized().cast<float>();
}

}  // namespace tsdf_mcl
