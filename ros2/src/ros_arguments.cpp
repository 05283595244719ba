#include "ros_arguments.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/localizer/parameter_file.hpp"

namespace tsdf_mcl::ros2_node {
namespace {

using node::ParameterValue;

const std::string kParametersKey = "ros__parameters";

std::vector<std::string> split(const std::string& text, char by) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t end; (end = text.find(by, start)) != std::string::npos; start = end + 1) {
    parts.push_back(text.substr(start, end - start));
  }
  parts.push_back(text.substr(start));
  return parts;
}

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

bool matches_parts(const std::vector<std::string>& pattern, std::size_t p, const std::vector<std::string>& name,
                   std::size_t n) {
  if (p == pattern.size()) return n == name.size();
  if (pattern[p] == "**") {
    for (std::size_t k = n; k <= name.size(); ++k) {
      if (matches_parts(pattern, p + 1, name, k)) return true;
    }
    return false;
  }
  if (n == name.size()) return false;
  return (pattern[p] == "*" || pattern[p] == name[n]) && matches_parts(pattern, p + 1, name, n + 1);
}

// "[nodename:]lhs:=rhs" of a -r or -p rule.
struct Rule {
  std::string node, lhs, rhs;
};

Rule parse_rule(const std::string& flag, const std::string& text) {
  const std::size_t assign = text.find(":=");
  if (assign == std::string::npos || assign == 0) {
    throw Error(flag + " expects name:=value, got '" + one_line(text) + "'");
  }
  Rule r;
  r.lhs = text.substr(0, assign);
  r.rhs = text.substr(assign + 2);
  const std::size_t colon = r.lhs.find(':');
  if (colon != std::string::npos) {
    r.node = r.lhs.substr(0, colon);
    r.lhs = r.lhs.substr(colon + 1);
  }
  return r;
}

// The entries of a parameter file (read_parameter_file: nested keys joined by '.') that belong to `node`: those under
// a node pattern that matches it, wildcard patterns first so that an entry naming the node wins.
void add_parameter_file(const std::string& file, const NodeName& node, node::NodeParameters& out) {
  // point_topics is a list however long, one topic included.
  const auto list_field = [](const std::string& field) {
    const std::string name = "." + kParametersKey + ".point_topics";
    return field.size() >= name.size() && field.compare(field.size() - name.size(), name.size(), name) == 0;
  };
  const std::map<std::string, std::string> values = read_parameter_file(file, list_field);
  const std::string fqn = node.fully_qualified();
  for (const bool wildcard_pass : {true, false}) {
    for (const auto& [key, text] : values) {
      const std::size_t at = key.find("." + kParametersKey + ".");
      if (at == std::string::npos) {
        if (key.find(kParametersKey) == std::string::npos) {
          throw Error(one_line(file) + ": '" + one_line(key) + "' lies under no '<node name>: " + kParametersKey +
                      ":' (a ROS 2 parameter file)");
        }
        continue;
      }
      std::string pattern = key.substr(0, at);
      std::replace(pattern.begin(), pattern.end(), '.', '/');  // nested node names: robot1: tsdf_mcl: ...
      if ((pattern.find('*') != std::string::npos) != wildcard_pass) continue;
      if (!node_pattern_matches(pattern, fqn)) continue;
      out.values[key.substr(at + kParametersKey.size() + 2)] = typed_value(text);
    }
  }
}

}  // namespace

bool node_pattern_matches(const std::string& pattern, const std::string& fully_qualified) {
  const std::string p = pattern.empty() || pattern.front() != '/' ? "/" + pattern : pattern;
  const std::vector<std::string> pp = split(p.substr(1), '/'), np = split(fully_qualified.substr(1), '/');
  return matches_parts(pp, 0, np, 0);
}

ParameterValue typed_value(const std::string& raw) {
  const std::string text = trim(raw);
  if (text.size() >= 2 && text.front() == '[' && text.back() == ']') {
    std::string joined;
    for (const std::string& item : split(text.substr(1, text.size() - 2), ',')) {
      joined += (joined.empty() ? "" : ",") + trim(item);
    }
    return {ParameterValue::Type::kList, joined};
  }
  if (text.size() >= 2 && (text.front() == '\'' || text.front() == '"') && text.back() == text.front()) {
    return {ParameterValue::Type::kString, text.substr(1, text.size() - 2)};
  }
  if (text.empty()) return {ParameterValue::Type::kString, ""};
  char* end = nullptr;
  errno = 0;
  std::strtoll(text.c_str(), &end, 10);
  if (*end == '\0' && errno == 0) return {ParameterValue::Type::kInteger, text};
  for (const auto& [yaml, c] : {std::pair<const char*, const char*>{".nan", "nan"},
                                {".NaN", "nan"},
                                {".inf", "inf"},
                                {"+.inf", "inf"},
                                {"-.inf", "-inf"},
                                {".Inf", "inf"},
                                {"-.Inf", "-inf"}}) {
    if (text == yaml) return {ParameterValue::Type::kDouble, c};
  }
  std::strtod(text.c_str(), &end);
  if (*end == '\0') return {ParameterValue::Type::kDouble, text};
  std::string lower = text;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower == "true" || lower == "false") return {ParameterValue::Type::kBool, lower};
  return {ParameterValue::Type::kString, text};
}

RosArguments parse_ros_arguments(const std::vector<std::string>& args) {
  RosArguments out;
  std::vector<std::pair<bool, std::string>> parameter_sources;  // (is a file, file or rule), in order
  bool ros_args = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    const auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw Error(a + " needs a value");
      return args[++i];
    };
    if (a == "--ros-args") {
      ros_args = true;
    } else if (a == "--") {
      ros_args = false;
    } else if (!ros_args) {
      if (a == "--help" || a == "-h") {
        out.help = true;
      } else {
        throw Error("unknown argument '" + one_line(a) + "' (ROS arguments follow --ros-args; --help)");
      }
    } else if (a == "-r" || a == "--remap") {
      const Rule r = parse_rule(a, value());
      if (r.lhs == "__ns") {
        out.node.ns = r.rhs.size() > 1 && r.rhs.back() == '/' ? r.rhs.substr(0, r.rhs.size() - 1) : r.rhs;
        if (out.node.ns.empty() || out.node.ns.front() != '/') out.node.ns = "/" + out.node.ns;
        if (out.node.ns != "/" && !topic_name_problem(out.node.ns).empty()) {
          throw Error("-r __ns:=" + one_line(r.rhs) + ": not a namespace (" + topic_name_problem(out.node.ns) + ")");
        }
      } else if (r.lhs == "__node" || r.lhs == "__name") {
        if (r.rhs.empty() || r.rhs.find('/') != std::string::npos || !topic_name_problem(r.rhs).empty()) {
          throw Error("-r __node:=" + one_line(r.rhs) + ": not a node name");
        }
        out.node.name = r.rhs;
      } else {
        out.remaps.push_back({r.node, r.lhs, r.rhs});
      }
    } else if (a == "-p" || a == "--param") {
      parameter_sources.emplace_back(false, value());
    } else if (a == "--params-file") {
      parameter_sources.emplace_back(true, value());
    } else if (a == "-e" || a == "--enclave" || a == "--log-level" || a == "--log-config-file") {
      out.notes.push_back(a + " " + one_line(value()) + " (not used by this node)");
    } else if (a.rfind("--enable-", 0) == 0 || a.rfind("--disable-", 0) == 0) {
      out.notes.push_back(a + " (not used by this node)");
    } else {
      throw Error("unknown ROS argument '" + one_line(a) +
                  "' (this node reads -r, -p, --params-file; logging and enclave options are accepted)");
    }
  }
  // The node's name is known only now (-r __node may follow --params-file).
  for (const auto& [is_file, source] : parameter_sources) {
    if (is_file) {
      add_parameter_file(source, out.node, out.parameters);
      continue;
    }
    const Rule r = parse_rule("-p", source);
    if (!r.node.empty() && !node_pattern_matches(r.node, out.node.fully_qualified()) && r.node != out.node.name) {
      continue;
    }
    out.parameters.values[r.lhs] = typed_value(r.rhs);
  }
  return out;
}

}  // namespace tsdf_mcl::ros2_node
