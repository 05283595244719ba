#include "tsdf_mcl/localizer/parameter_file.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {
namespace {

constexpr int kMaxDepth = 32;

// UTF-16/32 (with or without a byte-order mark) and binary files hold NUL bytes; yaml-cpp would read some of them
// as a map of garbage or convert them silently.
void check_text(const std::string& text, const std::string& file) {
  const auto starts = [&](const char* bom, std::size_t n) {
    return text.size() >= n && text.compare(0, n, bom, n) == 0;
  };
  if (starts("\xFF\xFE", 2) || starts("\xFE\xFF", 2)) {
    throw Error(file + ": UTF-16 or UTF-32 text; save the parameter file as UTF-8");
  }
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    throw Error(file + ": NUL byte at offset " + std::to_string(nul) +
                " (UTF-16 or binary?); a parameter file is UTF-8 text");
  }
}

// A scalar's text; Error for control characters (YAML "\0", "\x01" escapes) and numbers a double cannot hold.
std::string scalar_text(const YAML::Node& node, const std::string& file, const std::string& field) {
  const std::string v = node.as<std::string>();
  for (const char c : v) {
    if (static_cast<unsigned char>(c) < 0x20 && c != '\t') {
      throw Error(file + ": " + field + ": the value holds a control character (" +
                  (c == '\0' ? std::string("NUL") : "code " + std::to_string(static_cast<int>(c))) + ")");
    }
  }
  // An unquoted number that overflows (1e999, 99999999999999999999) would otherwise reach a parameter as text that
  // parses as infinity or fails far from its file.
  if (node.Tag() != "!" && !v.empty() &&
      (std::isdigit(static_cast<unsigned char>(v[0])) || v[0] == '-' || v[0] == '+')) {
    errno = 0;
    char* end = nullptr;
    const double d = std::strtod(v.c_str(), &end);
    const bool number = end == v.c_str() + v.size();
    bool out_of_range = number && (errno == ERANGE || !std::isfinite(d)) && std::abs(d) > 1.0;
    if (number && v.find_first_not_of("+-0123456789") == std::string::npos) {  // an integer: 64 bits at most
      errno = 0;
      (void)std::strtoll(v.c_str(), &end, 10);
      out_of_range = out_of_range || errno == ERANGE;
    }
    if (out_of_range) throw Error(file + ": " + field + ": the number " + v + " is out of range");
  }
  return v;
}

bool is_json(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  return ext == ".json" || ext == ".JSON";
}

// YAML reads JSON as flow style, which also allows what JSON does not (a trailing comma, comments, unquoted words);
// a .json file is held to JSON.
void check_strict_json(const std::string& text, const std::string& path) {
  try {
    const nlohmann::json parsed = nlohmann::json::parse(text);
    static_cast<void>(parsed);  // only whether it parses matters
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(path + ": not valid JSON: " + one_line(e.what()));
  } catch (const nlohmann::json::exception&) {
    // A number beyond a double's range: the field is named below (scalar_text).
  }
}

// Counts a text's YAML documents, stopping at two. yaml-cpp 0.7's LoadAll never ends on some malformed texts
// (",:red" parses as an endless run of empty documents), so the documents are counted, capped, before one is loaded.
int count_documents(const std::string& text) {
  struct DocumentCounter : YAML::EventHandler {
    int documents = 0;
    void OnDocumentStart(const YAML::Mark&) override { ++documents; }
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
    void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
    void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
    void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
    void OnMapEnd() override {}
  };
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentCounter counter;
  int parsed = 0;
  while (parsed < 2 && parser.HandleNextDocument(counter)) ++parsed;
  return parsed;
}

class Flattener {
 public:
  Flattener(std::string file, std::function<bool(const std::string&)> list_field)
      : file_(std::move(file)), list_field_(std::move(list_field)) {}

  void add(const YAML::Node& node, const std::string& prefix, int depth) {
    visit();
    if (depth > kMaxDepth) throw Error(file_ + ": nested more than " + std::to_string(kMaxDepth) + " levels deep");
    if (node.IsMap()) {
      for (const auto& kv : node) {
        if (!kv.first.IsScalar()) throw Error(file_ + ": " + prefix + ": keys must be names, not lists or maps");
        const std::string key = scalar_text(kv.first, file_, prefix.empty() ? "a key" : prefix);
        add(kv.second, prefix.empty() ? key : prefix + "." + key, depth + 1);
      }
    } else if (node.IsSequence()) {
      // A list is the value of a parameter that takes several (init's six numbers, init_height_band's two); one of
      // a single item would otherwise read as that item ({"sigma_hit": [1]}), an empty one as an empty value.
      if (node.size() < (list_field_ && list_field_(prefix) ? 1u : 2u)) {
        throw Error(file_ + ": " + prefix + ": a list of " + std::to_string(node.size()) +
                    " items; give a single value without brackets");
      }
      std::string joined;
      for (const auto& item : node) {
        if (!item.IsScalar()) throw Error(file_ + ": " + prefix + ": lists may only hold numbers or words");
        visit();
        joined += (joined.empty() ? "" : ",") + scalar_text(item, file_, prefix);
      }
      store(prefix, joined);
    } else if (node.IsScalar()) {
      store(prefix, scalar_text(node, file_, prefix));
    } else {
      throw Error(file_ + ": " + prefix + " has no value");
    }
  }

  std::map<std::string, std::string> values() && { return std::move(values_); }

 private:
  void store(const std::string& field, const std::string& value) {
    if (!values_.emplace(field, value).second) throw Error(file_ + ": " + field + " is given twice");
  }
  // Nodes are counted as visited, not as stored: aliases make the tree exponentially larger than the text.
  void visit() {
    if (++visited_ > limits::kMaxConfigValues) {
      throw Error(file_ + ": more than " + std::to_string(limits::kMaxConfigValues) +
                  " values (YAML aliases expand to more than any parameter file needs)");
    }
  }

  std::string file_;
  std::function<bool(const std::string&)> list_field_;
  std::size_t visited_ = 0;
  std::map<std::string, std::string> values_;
};

}  // namespace

std::map<std::string, std::string> read_parameter_file(const std::string& path,
                                                       const std::function<bool(const std::string&)>& list_field) {
  const std::string text = read_input_file(path, "config file", limits::kMaxConfigFileBytes);
  check_text(text, path);
  if (is_json(path)) check_strict_json(text, path);
  try {
    // The parameters are the file's one document: a second one (after ---) would otherwise be dropped unread.
    if (count_documents(text) > 1) {
      throw Error(path + ": holds more than one YAML document (separated by ---?); a parameter file is one");
    }
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap()) throw Error(path + ": expected a map of parameter names to values");
    Flattener flattener(path, list_field);
    flattener.add(root, "", 0);
    return std::move(flattener).values();
  } catch (const YAML::Exception& e) {
    throw Error(path + ": not valid YAML/JSON: " + e.what());
  }
}

}  // namespace tsdf_mcl
