#include "options.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"

namespace tsdf_mcl::cli {

Options::Options(std::string command, std::string usage, std::vector<OptionSpec> specs, int argc, char** argv,
                 int first)
    : command_(std::move(command)), usage_(std::move(usage)), specs_(std::move(specs)) {
  for (const OptionSpec& s : specs_) {
    // One spelling across every command: nav2's snake_case (the names robotics users bring from AMCL).
    if (s.name.find('-') != std::string::npos) throw std::logic_error("option --" + s.name + " is not snake_case");
  }
  for (int i = first; i < argc; ++i) {
    std::string arg = argv[i];
    // "-o PATH" is the one short option of the command-line contract (docs/architecture.md): an alias of --output.
    if (arg == "-o") arg = "--output";
    if (arg == "--help" || arg == "-h" || arg == "--help-all") {
      help_ = true;
      help_all_ = help_all_ || arg == "--help-all";
      continue;
    }
    if (arg.rfind("--", 0) != 0 || arg.size() == 2) {
      positional_.push_back(arg);
      continue;
    }
    std::string name = arg.substr(2);
    std::optional<std::string> value;
    if (const auto eq = name.find('='); eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    const OptionSpec& s = spec(name);
    if (s.value_name.empty()) {
      if (value) throw Error("option --" + name + " takes no value");
      values_[name] = "1";
      continue;
    }
    if (!value) {
      if (i + 1 >= argc) throw Error("option --" + name + " needs a value (" + s.value_name + ")");
      value = argv[++i];
    }
    values_[name] = *value;
  }
}

const OptionSpec& Options::spec(const std::string& name) const {
  for (const auto& s : specs_) {
    if (s.name == name) return s;
  }
  if (name.find('-') != std::string::npos) {
    std::string snake = name;
    std::replace(snake.begin(), snake.end(), '-', '_');
    for (const auto& s : specs_) {
      if (s.name == snake)
        throw Error("unknown option --" + name + ": options are spelled with underscores, --" + snake);
    }
  }
  std::vector<std::string> known;
  for (const auto& s : specs_) known.push_back(s.name);
  const std::string close = did_you_mean(name, known, "--");
  throw Error("unknown option --" + name + (close.empty() ? " (see tsdf-mcl " + command_ + " --help)" : close));
}

namespace {

constexpr std::size_t kHelpWidth = 100;
constexpr std::size_t kHelpIndent = 30;

// `text` wrapped at kHelpWidth, every line after the first indented to `indent`; words longer than a line stay
// whole.
std::string wrap(const std::string& text, std::size_t first_column, std::size_t indent) {
  std::string out;
  std::size_t column = first_column;
  std::istringstream words(text);
  bool line_empty = true;
  for (std::string word; words >> word;) {
    if (!line_empty && column + 1 + word.size() > kHelpWidth) {
      out += "\n" + std::string(indent, ' ');
      column = indent;
      line_empty = true;
    }
    if (!line_empty) {
      out += ' ';
      ++column;
    }
    out += word;
    column += word.size();
    line_empty = false;
  }
  return out;
}

// The sections of a grouped --help, in this order; options of other groups follow.
const std::vector<std::string> kGroupOrder = {"input",        "initialization", "output",  "filter",
                                              "sensor model", "decision",       "runtime", "expert"};
// Shown by --help-all only.
const char* const kExpertGroup = "expert";

}  // namespace

std::string Options::help_text() const {
  std::ostringstream out;
  // The usage's lines as written, each wrapped at the width with its continuation indented under the command.
  std::istringstream usage("usage: " + usage_);
  for (std::string line; std::getline(usage, line);) {
    if (line.size() <= kHelpWidth) {
      out << line << "\n";
      continue;
    }
    const std::size_t lead = line.find_first_not_of(' ');
    const std::size_t indent = line.rfind("usage:", 0) == 0 ? 4 : std::min<std::size_t>(lead + 4, 40);
    out << std::string(lead, ' ') << wrap(line.substr(lead), lead, indent) << "\n";
  }
  std::vector<std::string> groups;
  for (const auto& g : kGroupOrder) {
    for (const auto& s : specs_) {
      if (s.group == g) {
        groups.push_back(g);
        break;
      }
    }
  }
  for (const auto& s : specs_) {
    if (std::find(groups.begin(), groups.end(), s.group) == groups.end()) groups.push_back(s.group);
  }
  bool hidden = false;
  for (const std::string& group : groups) {
    if (group == kExpertGroup && !help_all_) {
      hidden = true;
      continue;
    }
    out << "\n" << (group.empty() ? "options" : group + " options") << ":\n";
    for (const auto& s : specs_) {
      if (s.group != group) continue;
      std::string left =
          (s.name == "output" ? "  -o, --" : "  --") + s.name + (s.value_name.empty() ? "" : " " + s.value_name);
      if (left.size() + 1 < kHelpIndent)
        left.resize(kHelpIndent, ' ');
      else
        left += "\n" + std::string(kHelpIndent, ' ');
      std::string help = s.help;
      if (!s.default_value.empty()) help += " [default: " + s.default_value + "]";
      out << left << wrap(help, kHelpIndent, kHelpIndent) << "\n";
    }
  }
  if (hidden) out << "\n--help-all also lists the expert options.\n";
  return out.str();
}

bool Options::has(const std::string& name) const {
  spec(name);
  return values_.count(name) != 0;
}

bool Options::flag(const std::string& name) const {
  const auto v = maybe(name);
  return v && (*v == "1" || *v == "true" || *v == "yes" || *v == "on");
}

std::optional<std::string> Options::maybe(const std::string& name) const {
  const OptionSpec& s = spec(name);
  if (auto it = values_.find(name); it != values_.end()) return it->second;
  if (!s.default_value.empty()) return s.default_value;
  return std::nullopt;
}

std::string Options::text(const std::string& name) const {
  auto v = maybe(name);
  if (!v) throw Error("missing required option --" + name);
  return *v;
}

double Options::number(const std::string& name) const {
  const std::string v = text(name);
  errno = 0;
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || errno != 0 || !std::isfinite(d)) {
    throw Error("--" + name + " expects a number, got '" + v + "'");
  }
  return d;
}

long long Options::integer(const std::string& name) const {
  const std::string v = text(name);
  errno = 0;
  char* end = nullptr;
  const long long n = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno != 0) {
    throw Error("--" + name + " expects an integer, got '" + v + "'");
  }
  return n;
}

std::size_t Options::count(const std::string& name) const {
  const long long n = integer(name);
  if (n < 0) throw Error("--" + name + " must not be negative");
  return static_cast<std::size_t>(n);
}

std::size_t Options::count(const std::string& name, std::size_t max) const {
  const std::size_t n = count(name);
  if (n > max) throw Error("--" + name + " " + std::to_string(n) + " is more than the limit of " + std::to_string(max));
  return n;
}

std::vector<std::string> Options::list(const std::string& name) const {
  std::vector<std::string> out;
  std::stringstream ss(text(name));
  for (std::string item; std::getline(ss, item, ',');) {
    if (item.empty()) throw Error("--" + name + " has an empty item");
    out.push_back(item);
  }
  return out;
}

std::vector<double> Options::numbers(const std::string& name) const {
  std::vector<double> out;
  for (const std::string& item : list(name)) {
    char* end = nullptr;
    const double d = std::strtod(item.c_str(), &end);
    if (*end != '\0' || !std::isfinite(d)) {
      throw Error("--" + name + " expects comma-separated numbers, got '" + item + "'");
    }
    out.push_back(d);
  }
  return out;
}

void Options::expect_positional(std::size_t n, const std::string& what) const {
  if (positional_.size() != n) {
    throw Error("expected " + what + " (see tsdf-mcl " + command_ + " --help)");
  }
}

std::vector<std::filesystem::path> input_paths(const Options& o, const std::vector<std::string>& names) {
  std::vector<std::filesystem::path> paths;
  for (const std::string& name : names) {
    if (!o.has(name)) continue;
    const std::string text = o.text(name);
    paths.emplace_back(text);  // a file whose name holds a comma, whole
    std::stringstream ss(text);
    for (std::string item; std::getline(ss, item, ',');) {
      if (!item.empty() && item != text) paths.emplace_back(item);
    }
    std::error_code ec;
    if (std::filesystem::is_directory(text, ec)) {  // a dataset: its text files (docs/architecture.md)
      for (const char* file : {"times.txt", "poses.txt", "odom.txt", "imu.txt"}) {
        paths.push_back(std::filesystem::path(text) / file);
      }
    }
  }
  return paths;
}

double angle_in_degrees(const std::string& text, const std::string& what, double max_abs) {
  const bool has_unit =
      text.size() > 3 && (text.compare(text.size() - 3, 3, "deg") == 0 || text.compare(text.size() - 3, 3, "rad") == 0);
  return parse_angle(has_unit ? text : text + "deg", what, max_abs);
}

void Options::set_default_from_config(const std::string& name, const std::string& value) {
  spec(name);
  values_.emplace(name, value);
}

}  // namespace tsdf_mcl::cli
