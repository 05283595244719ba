#include "options.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include "tsdf_mcl/error.hpp"

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
    if (arg == "--help" || arg == "-h") {
      help_ = true;
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
  throw Error("unknown option --" + name + " (see tsdf-mcl " + command_ + " --help)");
}

std::string Options::help_text() const {
  std::ostringstream out;
  out << "usage: " << usage_ << "\n\noptions:\n";
  for (const auto& s : specs_) {
    std::string left =
        (s.name == "output" ? "  -o, --" : "  --") + s.name + (s.value_name.empty() ? "" : " " + s.value_name);
    if (left.size() < 30)
      left.resize(30, ' ');
    else
      left += "\n" + std::string(30, ' ');
    out << left << s.help;
    if (!s.default_value.empty()) out << " [default: " << s.default_value << "]";
    out << "\n";
  }
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

void Options::set_default_from_config(const std::string& name, const std::string& value) {
  spec(name);
  values_.emplace(name, value);
}

}  // namespace tsdf_mcl::cli
