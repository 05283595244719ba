#include "parameter_file.hpp"

#include <yaml-cpp/yaml.h>

#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/input_file.hpp"
#include "tsdf_mcl/limits.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
namespace {

constexpr int kMaxDepth = 32;

class Flattener {
 public:
  explicit Flattener(std::string file) : file_(std::move(file)) {}

  void add(const YAML::Node& node, const std::string& prefix, int depth) {
    visit();
    if (depth > kMaxDepth) throw Error(file_ + ": nested more than " + std::to_string(kMaxDepth) + " levels deep");
    if (node.IsMap()) {
      for (const auto& kv : node) {
        if (!kv.first.IsScalar()) throw Error(file_ + ": " + prefix + ": keys must be names, not lists or maps");
        const std::string key = kv.first.as<std::string>();
        add(kv.second, prefix.empty() ? key : prefix + "." + key, depth + 1);
      }
    } else if (node.IsSequence()) {
      std::string joined;
      for (const auto& item : node) {
        if (!item.IsScalar()) throw Error(file_ + ": " + prefix + ": lists may only hold numbers or words");
        visit();
        joined += (joined.empty() ? "" : ",") + item.as<std::string>();
      }
      values_.emplace_back(prefix, joined);
    } else if (node.IsScalar()) {
      values_.emplace_back(prefix, node.as<std::string>());
    } else {
      throw Error(file_ + ": " + prefix + " has no value");
    }
  }

  std::vector<std::pair<std::string, std::string>> values() && { return std::move(values_); }

 private:
  // Nodes are counted as visited, not as stored: aliases make the tree exponentially larger than the text.
  void visit() {
    if (++visited_ > limits::kMaxConfigValues) {
      throw Error(file_ + ": more than " + std::to_string(limits::kMaxConfigValues) +
                  " values (YAML aliases expand to more than any parameter file needs)");
    }
  }

  std::string file_;
  std::size_t visited_ = 0;
  std::vector<std::pair<std::string, std::string>> values_;
};

}  // namespace

std::vector<std::pair<std::string, std::string>> read_parameter_file(const fs::path& file) {
  const std::string text = read_input_file(file, "config file", limits::kMaxConfigFileBytes);
  const std::string name = file.string();
  try {
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap()) throw Error(name + ": expected a map of parameter names to values");
    Flattener flattener(name);
    flattener.add(root, "", 0);
    return std::move(flattener).values();
  } catch (const YAML::Exception& e) {
    throw Error(name + ": not valid YAML/JSON: " + e.what());
  }
}

}  // namespace tsdf_mcl
