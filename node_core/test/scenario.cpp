#include "scenario.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "message_checks.hpp"

namespace tsdf_mcl::node::test {
namespace {

RawPose raw_pose(const Pose& p) {
  const Eigen::Quaterniond q(p.rotation());
  RawPose r;
  r.position = p.translation();
  r.orientation = {q.x(), q.y(), q.z(), q.w()};
  return r;
}

}  // namespace

std::string Heard::value(const std::string& key) const {
  for (const auto& [k, v] : status.values)
    if (k == key) return v;
  return "";
}

std::size_t Heard::count(const std::string& key) const {
  const std::string v = value(key);
  return v.empty() ? 0 : std::stoul(v);
}

RawStamp raw(double seconds) {
  const auto ns = static_cast<std::int64_t>(std::llround(seconds * 1e9));
  return {ns / 1000000000, static_cast<std::uint32_t>(ns % 1000000000)};
}

double angle_deg(const Pose& a, const Pose& b) {
  return Eigen::AngleAxisd(a.rotation().transpose() * b.rotation()).angle() * 180.0 / M_PI;
}

bool run_cli(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(TSDF_MCL_CLI) + " " + args + " >>'" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(status, 0) << cmd << " failed; see " << log;
  return status == 0;
}

fs::path small_office() {
  const fs::path cli(TSDF_MCL_CLI);
  const fs::path cache(TSDF_MCL_NODE_TEST_CACHE);
  const std::string name = "office_" + std::to_string(fs::last_write_time(cli).time_since_epoch().count());
  fs::create_directories(cache);
  const int lock = open((cache / "lock").c_str(), O_RDWR | O_CREAT, 0644);
  EXPECT_GE(lock, 0) << cache / "lock";
  flock(lock, LOCK_EX);
  const fs::path dir = cache / name;
  if (!fs::exists(dir / "complete")) {
    for (const auto& entry : fs::directory_iterator(cache)) {
      if (entry.is_directory()) fs::remove_all(entry.path());  // an earlier build's, or one left half built
    }
    fs::create_directories(dir);
    const fs::path log = dir / "cli.log";
    if (run_cli("simulate --scene office --lidar vlp16 --route test --seed 2 --length 8 -o '" + (dir / "run").string() +
                    "'",
                log) &&
        run_cli("build-map --dataset '" + (dir / "run").string() + "' -o '" + (dir / "map.tsdf").string() + "'", log)) {
      std::ofstream(dir / "complete") << "built\n";
    }
  }
  flock(lock, LOCK_UN);
  close(lock);
  return dir;
}

std::vector<Played> play(NodeLink& link, const Dataset& data, const PlayOptions& o) {
  TransformMsg mounting;
  mounting.header = {raw(data.time(o.scans.front()) + o.time_offset), o.base_frame};
  mounting.child_frame_id = o.sensor_frame;
  link.tf({mounting}, true);
  std::vector<Played> played;
  std::size_t converged = 0;
  for (const std::size_t i : o.scans) {
    Played p;
    p.stamp = raw(data.time(i) + o.time_offset);
    p.truth = data.pose(i);
    p.odom_T_base = data.has_odometry() ? data.odometry(i) : data.pose(i);
    if (o.send_clock) link.clock(p.stamp);
    TransformMsg odom;
    odom.header = {p.stamp, o.odom_frame};
    odom.child_frame_id = o.base_frame;
    odom.transform = raw_pose(p.odom_T_base);
    link.tf({odom}, false);
    link.cloud(data.load_scan(i), p.stamp, o.sensor_frame);
    p.heard = link.heard(p.stamp, std::chrono::seconds(120));
    if (!p.heard) ADD_FAILURE() << "no answer to the scan at " << p.stamp.sec << "." << p.stamp.nanosec << " s";
    if (p.heard && p.heard->used()) p.map_odom = link.map_odom(p.stamp, std::chrono::seconds(60));
    if (p.heard && p.heard->status.message == "converged") ++converged;
    played.push_back(std::move(p));
    if (::testing::Test::HasFatalFailure() || !played.back().heard) break;
    if (o.stop_after_converged > 0 && converged >= o.stop_after_converged) break;
  }
  return played;
}

Outcome summarize(const std::vector<Played>& played) {
  Outcome o;
  o.scans = played.size();
  double sq = 0.0;
  for (std::size_t k = 0; k < played.size(); ++k) {
    const Played& p = played[k];
    if (!p.heard) continue;
    ++o.answered;
    const std::string state = p.heard->status.message;
    if (o.answered == 1) o.first_state = state;
    o.last_state = state;
    if (state != "converged" || !p.heard->pose) continue;
    const Pose& estimate = p.heard->pose->pose;
    const double err = (estimate.translation() - p.truth.translation()).norm();
    if (err > 1.0 || angle_deg(estimate, p.truth) > 10.0) ++o.false_claims;
    if (!o.first_converged) o.first_converged = k;
    ++o.converged;
    sq += err * err;
    if (p.map_odom) {
      const Pose map_T_base = p.map_odom->pose * p.odom_T_base;
      o.max_tf_error_m = std::max(o.max_tf_error_m, (map_T_base.translation() - p.truth.translation()).norm());
      o.max_tf_error_deg = std::max(o.max_tf_error_deg, angle_deg(map_T_base, p.truth));
      ++o.tf_checked;
    }
  }
  if (o.converged > 0) o.rmse_m = std::sqrt(sq / static_cast<double>(o.converged));
  return o;
}

std::string describe(const Outcome& o) {
  char buf[400];
  std::snprintf(buf, sizeof(buf),
                "%zu scans, %zu answered, converged from scan %d, %zu converged (%zu false), ATE %.3f m, tf map -> "
                "base worst %.3f m / %.2f deg over %zu, first state %s, last %s",
                o.scans, o.answered, o.first_converged ? static_cast<int>(*o.first_converged) : -1, o.converged,
                o.false_claims, o.rmse_m, o.max_tf_error_m, o.max_tf_error_deg, o.tf_checked, o.first_state.c_str(),
                o.last_state.c_str());
  return buf;
}

}  // namespace tsdf_mcl::node::test
