#pragma once
// A small declarative option parser: each command lists its options (name, default, help), so unknown
// options, missing values and bad numbers are caught in one place and --help prints every default.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace tsdf_mcl::cli {

struct OptionSpec {
  std::string name;           // without the leading "--"
  std::string value_name;     // empty for a flag
  std::string default_value;  // shown by --help; empty = no default
  std::string help;
  std::string group = {};  // --help section ("input", "initialization", ...); empty = the command's only one
};

class Options {
 public:
  // Parses argv[first..]: "--name value", "--name=value", "--flag", positional arguments; "-o" stands for "--output".
  // Throws Error for an unknown option or a missing value. Sets help_requested() for --help / -h and --help-all
  // (which also lists the options of the "expert" group).
  Options(std::string command, std::string usage, std::vector<OptionSpec> specs, int argc, char** argv, int first);

  bool help_requested() const { return help_; }
  std::string help_text() const;

  bool has(const std::string& name) const;  // given on the command line (or from a config file)
  bool flag(const std::string& name) const;
  std::string text(const std::string& name) const;  // value or default
  std::optional<std::string> maybe(const std::string& name) const;
  double number(const std::string& name) const;  // finite, else Error naming the option
  long long integer(const std::string& name) const;
  std::size_t count(const std::string& name) const;                   // non-negative integer
  std::size_t count(const std::string& name, std::size_t max) const;  // ... at most max (else Error naming it)
  std::vector<double> numbers(const std::string& name) const;         // comma-separated
  std::vector<std::string> list(const std::string& name) const;       // comma-separated
  const std::vector<std::string>& positional() const { return positional_; }
  // Requires exactly n positional arguments (named in the message).
  void expect_positional(std::size_t n, const std::string& what) const;
  // Sets a value unless the command line already gave it (config files feed in here).
  void set_default_from_config(const std::string& name, const std::string& value);
  const std::vector<OptionSpec>& specs() const { return specs_; }
  const std::string& command() const { return command_; }

 private:
  const OptionSpec& spec(const std::string& name) const;
  std::string command_;
  std::string usage_;
  std::vector<OptionSpec> specs_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
  bool help_ = false;
  bool help_all_ = false;
};

// The files the given options among `names` name (comma-separated lists split; a dataset folder's text files), for
// check_output_file's inputs: an output must not replace one of the command's own inputs.
std::vector<std::filesystem::path> input_paths(const Options& o, const std::vector<std::string>& names);

// An angle as text in degrees, or with an explicit unit ("90deg", "1.57rad"); radians back. Error naming `what`
// for a non-number or a magnitude beyond max_abs radians.
double angle_in_degrees(const std::string& text, const std::string& what, double max_abs);

}  // namespace tsdf_mcl::cli
