// The project's command-line front end: the part of CLI11's API that fieldline's programs use,
// compiled once (common/cli/cli.cpp is the only file that includes <CLI/CLI.hpp>). CLI11 is
// header-only and costs about 14 CPU-s in every file that includes it; this header costs a
// fraction of a second. Call sites read as with CLI11: `cli::App app{"..."};`,
// `app.add_option("--rate", rate, "Hz")->check(cli::Range(1.0, 100.0))->capture_default_str();`.
// Help text, error messages and exit codes are CLI11's own (the options are CLI11 options).
#pragma once

#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace fieldline::cli {

// A check on an option's value, as a plain value: CLI11's validator is built from it when the
// option gets it (Option::check).
class Validator {
 public:
  enum class Kind : std::uint8_t {
    kRangeInt,
    kRangeInt64,
    kRangeDouble,
    kPositiveNumber,
    kNonNegativeNumber,
    kMemberStrings,
    kMemberInts,
    kExistingFile,
    kExistingPath,
    kExistingDirectory,
  };
  explicit Validator(Kind kind) : kind_(kind) {}

  Kind kind() const { return kind_; }
  std::int64_t minInt() const { return min_int_; }
  std::int64_t maxInt() const { return max_int_; }
  double minDouble() const { return min_double_; }
  double maxDouble() const { return max_double_; }
  const std::vector<std::string>& strings() const { return strings_; }
  const std::vector<int>& ints() const { return ints_; }

 private:
  friend class Range;
  friend class IsMember;
  Kind kind_;
  std::int64_t min_int_ = 0;
  std::int64_t max_int_ = 0;
  double min_double_ = 0.0;
  double max_double_ = 0.0;
  std::vector<std::string> strings_;
  std::vector<int> ints_;
};

// CLI::Range: min and max inclusive; the help shows "INT in [a - b]" or "FLOAT in [a - b]" after
// the type of the bounds, as CLI11 does.
class Range : public Validator {
 public:
  Range(int min, int max);
  Range(std::int64_t min, std::int64_t max);
  Range(double min, double max);
};

// CLI::IsMember: the value must be one of these.
class IsMember : public Validator {
 public:
  IsMember(std::initializer_list<std::string> values);
  explicit IsMember(std::vector<std::string> values);
  IsMember(std::initializer_list<int> values);
};

inline const Validator PositiveNumber{Validator::Kind::kPositiveNumber};
inline const Validator NonNegativeNumber{Validator::Kind::kNonNegativeNumber};
inline const Validator ExistingFile{Validator::Kind::kExistingFile};
inline const Validator ExistingPath{Validator::Kind::kExistingPath};
inline const Validator ExistingDirectory{Validator::Kind::kExistingDirectory};

// What App::parse throws for --help and for bad arguments (CLI::ParseError); App::exit prints it.
class ParseError : public std::runtime_error {
 public:
  ParseError(const std::string& what, std::exception_ptr cause)
      : std::runtime_error(what), cause_(std::move(cause)) {}
  // The CLI11 exception inside.
  const std::exception_ptr& cause() const { return cause_; }

 private:
  std::exception_ptr cause_;
};

// CLI::ValidationError: throw it after App::parse for a combination of options that is not
// allowed; App::exit prints it as CLI11 would and returns its (non-zero) code.
class ValidationError : public ParseError {
 public:
  ValidationError(const std::string& name, const std::string& message);
};

class App;

// A handle on one option of an App (CLI::Option*); valid as long as the App.
class Option {
 public:
  Option* check(const Validator& validator);
  // A check of one's own: returns the problem, or an empty string when the value is fine.
  Option* check(std::function<std::string(const std::string&)> validator);
  Option* capture_default_str();
  Option* required(bool value = true);
  Option* excludes(Option* other);
  Option* delimiter(char value);
  Option* expected(int value);
  Option* allow_extra_args(bool value = true);
  // How many times the option was given.
  std::size_t count() const;

 private:
  friend class App;
  explicit Option(CLI::Option* option) : option_(option) {}
  CLI::Option* option_;
};

class App {
 public:
  explicit App(const std::string& description = "", const std::string& name = "");
  ~App();
  App(const App&) = delete;
  App& operator=(const App&) = delete;

  Option* add_option(const std::string& name, int& value, const std::string& description = "");
  Option* add_option(const std::string& name, unsigned& value, const std::string& description = "");
  Option* add_option(const std::string& name, std::int64_t& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, std::uint64_t& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, double& value, const std::string& description = "");
  // An option that takes a value (--carry-track 0); add_flag for one that does not.
  Option* add_option(const std::string& name, bool& value, const std::string& description = "");
  Option* add_option(const std::string& name, std::string& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, std::vector<std::string>& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, std::vector<int>& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, std::vector<double>& value,
                     const std::string& description = "");
  // Set only when given.
  Option* add_option(const std::string& name, std::optional<int>& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, std::optional<double>& value,
                     const std::string& description = "");
  Option* add_option(const std::string& name, std::optional<std::string>& value,
                     const std::string& description = "");
  Option* add_flag(const std::string& name, bool& value, const std::string& description = "");
  // A file of `name = value` lines read as options (CLI11's set_config).
  Option* set_config(const std::string& name, const std::string& default_file,
                     const std::string& description);
  App* footer(const std::string& text);

  // Throws ParseError for --help and for bad arguments.
  void parse(int argc, char** argv);
  // Prints the help or the problem of `error` as CLI11 does; returns CLI11's exit code (0 after
  // --help).
  int exit(const ParseError& error) const;

 private:
  struct Impl;
  Option* wrap(CLI::Option* option);
  std::unique_ptr<Impl> impl_;
};

}  // namespace fieldline::cli

// CLI11_PARSE: parses or returns CLI11's own exit code from main() (0 after --help; 105 for a
// value out of range, ...). Mains of the robot use FIELDLINE_PARSE (common/bus/cli.hpp): 2.
#define FIELDLINE_CLI_PARSE(app, argc, argv)        \
  try {                                             \
    (app).parse((argc), (argv));                    \
  } catch (const ::fieldline::cli::ParseError& e) { \
    return (app).exit(e);                           \
  }
