#include "ros_names.hpp"

#include <cctype>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::ros2_node {
namespace {

bool valid_token(const std::string& t) {
  if (t.empty() || std::isdigit(static_cast<unsigned char>(t[0]))) return false;
  for (const char c : t) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  return true;
}

}  // namespace

std::string NodeName::fully_qualified() const { return ns == "/" ? "/" + name : ns + "/" + name; }

std::string topic_name_problem(const std::string& name) {
  if (name.empty()) return "is empty";
  if (name == "~") return "";
  std::string rest = name;
  if (rest.rfind("~/", 0) == 0) rest = rest.substr(2);
  if (rest.front() == '/') rest = rest.substr(1);
  if (rest.empty() || rest.back() == '/') return "ends with '/'";
  std::size_t start = 0;
  while (start <= rest.size()) {
    const std::size_t end = rest.find('/', start);
    const std::string token = rest.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!valid_token(token)) {
      return "has the part '" + one_line(token) +
             "' (parts are letters, digits and underscores, not starting with a digit, between single slashes)";
    }
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return "";
}

std::string NameResolver::expand(const std::string& name) const {
  const std::string problem = topic_name_problem(name);
  if (!problem.empty()) throw Error("the name '" + one_line(name) + "' " + problem);
  const std::string private_ns = node_.fully_qualified();
  if (name == "~") return private_ns;
  if (name.rfind("~/", 0) == 0) return private_ns + name.substr(1);
  if (name.front() == '/') return name;
  return (node_.ns == "/" ? "" : node_.ns) + "/" + name;
}

std::string NameResolver::resolve(const std::string& name) const {
  const std::string expanded = expand(name);
  for (const Remap& r : remaps_) {
    if (!r.node.empty() && r.node != node_.name) continue;
    if (r.from.rfind("__", 0) == 0) continue;  // __ns, __node: the node's own, not a topic's
    if (expand(r.from) == expanded) return expand(r.to);
  }
  return expanded;
}

std::string dds_topic(const std::string& fully_qualified) { return "rt" + fully_qualified; }
std::string dds_request_topic(const std::string& fully_qualified) { return "rq" + fully_qualified + "Request"; }
std::string dds_reply_topic(const std::string& fully_qualified) { return "rr" + fully_qualified + "Reply"; }

}  // namespace tsdf_mcl::ros2_node
