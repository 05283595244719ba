#include "tsdf_mcl/io/transform_tree.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/bag_messages.hpp"

namespace tsdf_mcl {
namespace {

std::string seconds(double t) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.9g", t);
  return buf;
}

using msg::quoted_name;

}  // namespace

Pose interpolate_pose(const Pose& a, const Pose& b, double f) {
  Pose out = Pose::Identity();
  out.linear() =
      Eigen::Quaterniond(a.linear()).slerp(f, Eigen::Quaterniond(b.linear())).normalized().toRotationMatrix();
  out.translation() = (1.0 - f) * a.translation() + f * b.translation();
  return out;
}

void TransformTree::add(const std::string& parent, const std::string& child, double time, const Pose& parent_T_child,
                        bool is_static) {
  if (parent == child) throw Error("tf transform from frame " + quoted_name(child) + " to itself");
  if (parent.empty() || child.empty())
    throw Error("tf transform with an empty frame name (" + quoted_name(parent) + " -> " + quoted_name(child) + ")");
  // A corrupt or absurd transform (1e300 m) would turn every pose downstream into NaN: one error here instead.
  constexpr double kMaxTranslation = 1e6;  // m: no map spans 1000 km
  if (!parent_T_child.matrix().allFinite() || parent_T_child.translation().cwiseAbs().maxCoeff() > kMaxTranslation) {
    const Eigen::Vector3d t = parent_T_child.translation();
    char buf[160];
    std::snprintf(buf, sizeof(buf), "translation (%g, %g, %g) m is not finite or beyond %g m", t.x(), t.y(), t.z(),
                  kMaxTranslation);
    throw Error("tf " + quoted_name(parent) + " -> " + quoted_name(child) + ": " + buf);
  }
  auto [it, inserted] = edges_.try_emplace(child);
  Edge& e = it->second;
  if (inserted) {
    e.parent = parent;
    e.is_static = is_static;
  } else if (e.parent != parent) {
    throw Error("tf frame " + quoted_name(child) + " has two parents, " + quoted_name(e.parent) + " and " +
                quoted_name(parent));
  } else if (e.is_static != is_static) {
    throw Error("tf " + quoted_name(parent) + " -> " + quoted_name(child) +
                " is both static (/tf_static) and dynamic (/tf)");
  }
  if (is_static) {
    e.samples.assign(1, {time, parent_T_child});
    return;
  }
  // Samples arrive nearly in order: append, or insert at their place.
  auto pos = std::upper_bound(e.samples.begin(), e.samples.end(), time,
                              [](double t, const std::pair<double, Pose>& s) { return t < s.first; });
  if (pos != e.samples.begin() && std::prev(pos)->first == time) {
    std::prev(pos)->second = parent_T_child;
  } else {
    e.samples.insert(pos, {time, parent_T_child});
  }
}

bool TransformTree::has_frame(const std::string& frame) const {
  if (edges_.count(frame)) return true;
  return std::any_of(edges_.begin(), edges_.end(), [&](const auto& kv) { return kv.second.parent == frame; });
}

std::vector<std::string> TransformTree::frames() const {
  std::set<std::string> names;
  for (const auto& [child, edge] : edges_) {
    names.insert(child);
    names.insert(edge.parent);
  }
  return {names.begin(), names.end()};
}

std::vector<std::string> TransformTree::chain(const std::string& frame) const {
  std::vector<std::string> out{frame};
  for (auto it = edges_.find(frame); it != edges_.end(); it = edges_.find(out.back())) {
    if (out.size() > edges_.size()) throw Error("tf frames form a loop through " + quoted_name(frame));
    out.push_back(it->second.parent);
  }
  return out;
}

std::string TransformTree::common_ancestor(const std::string& target, const std::string& source) const {
  const std::vector<std::string> up_target = chain(target), up_source = chain(source);
  for (const std::string& f : up_source) {
    if (std::find(up_target.begin(), up_target.end(), f) != up_target.end()) return f;
  }
  auto known = [&](const std::string& f) {
    return has_frame(f) ? "" : " (" + quoted_name(f) + " is in no tf message)";
  };
  std::string frames_list;
  for (const std::string& f : frames()) frames_list += (frames_list.empty() ? "" : ", ") + msg::printable_name(f);
  throw Error("no tf connects " + quoted_name(target) + " and " + quoted_name(source) + known(target) + known(source) +
              "; the tf frames are: " + (frames_list.empty() ? "none" : frames_list));
}

Pose TransformTree::at(const std::string& child, const Edge& edge, double time) {
  if (edge.is_static) return edge.samples.front().second;
  const auto& s = edge.samples;
  // Stamps are nanoseconds in a bag: a query within a nanosecond of the ends is at the end.
  constexpr double kSlack = 1e-9;
  if (time < s.front().first - kSlack || time > s.back().first + kSlack) {
    throw Error("tf " + quoted_name(edge.parent) + " -> " + quoted_name(child) + " is known from " +
                seconds(s.front().first) + " to " + seconds(s.back().first) + " s, not at " + seconds(time) +
                " s (tf is not extrapolated)");
  }
  auto hi = std::lower_bound(s.begin(), s.end(), time,
                             [](const std::pair<double, Pose>& a, double t) { return a.first < t; });
  if (hi == s.end()) return s.back().second;
  if (hi->first - time <= kSlack || hi == s.begin()) return hi->second;
  const auto lo = std::prev(hi);
  if (time - lo->first <= kSlack) return lo->second;
  return interpolate_pose(lo->second, hi->second, (time - lo->first) / (hi->first - lo->first));
}

Pose TransformTree::down_to(const std::string& ancestor, const std::string& frame, double time) const {
  Pose out = Pose::Identity();
  for (std::string f = frame; f != ancestor;) {
    const Edge& e = edges_.at(f);
    out = at(f, e, time) * out;
    f = e.parent;
  }
  return out;
}

Pose TransformTree::lookup(const std::string& target, const std::string& source, double time) const {
  if (target == source) return Pose::Identity();
  const std::string ancestor = common_ancestor(target, source);
  return down_to(ancestor, target, time).inverse() * down_to(ancestor, source, time);
}

std::pair<double, double> TransformTree::coverage(const std::string& target, const std::string& source) const {
  std::pair<double, double> range{-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  if (target == source) return range;
  const std::string ancestor = common_ancestor(target, source);
  for (const std::string& frame : {target, source}) {
    for (std::string f = frame; f != ancestor;) {
      const Edge& e = edges_.at(f);
      if (!e.is_static) {
        range.first = std::max(range.first, e.samples.front().first);
        range.second = std::min(range.second, e.samples.back().first);
      }
      f = e.parent;
    }
  }
  return range;
}

}  // namespace tsdf_mcl
