#include "common/cli/cli.hpp"

#include <deque>
#include <utility>

#include <CLI/CLI.hpp>

namespace fieldline::cli {

Range::Range(int min, int max) : Validator(Kind::kRangeInt) {
  min_int_ = min;
  max_int_ = max;
}

Range::Range(std::int64_t min, std::int64_t max) : Validator(Kind::kRangeInt64) {
  min_int_ = min;
  max_int_ = max;
}

Range::Range(double min, double max) : Validator(Kind::kRangeDouble) {
  min_double_ = min;
  max_double_ = max;
}

IsMember::IsMember(std::initializer_list<std::string> values) : Validator(Kind::kMemberStrings) {
  strings_ = values;
}

IsMember::IsMember(std::vector<std::string> values) : Validator(Kind::kMemberStrings) {
  strings_ = std::move(values);
}

IsMember::IsMember(std::initializer_list<int> values) : Validator(Kind::kMemberInts) {
  ints_ = values;
}

ValidationError::ValidationError(const std::string& name, const std::string& message)
    : ParseError(CLI::ValidationError(name, message).what(),
                 std::make_exception_ptr(CLI::ValidationError(name, message))) {}

namespace {

// CLI11's validator for `v`: the same template arguments as the call sites used to give.
CLI::Validator toCli(const Validator& v) {
  using Kind = Validator::Kind;
  switch (v.kind()) {
    case Kind::kRangeInt:
      return CLI::Range(static_cast<int>(v.minInt()), static_cast<int>(v.maxInt()));
    case Kind::kRangeInt64:
      return CLI::Range(v.minInt(), v.maxInt());
    case Kind::kRangeDouble:
      return CLI::Range(v.minDouble(), v.maxDouble());
    case Kind::kPositiveNumber:
      return CLI::PositiveNumber;
    case Kind::kNonNegativeNumber:
      return CLI::NonNegativeNumber;
    case Kind::kMemberStrings:
      return CLI::IsMember(v.strings());
    case Kind::kMemberInts:
      return CLI::IsMember(v.ints());
    case Kind::kExistingFile:
      return CLI::ExistingFile;
    case Kind::kExistingPath:
      return CLI::ExistingPath;
    case Kind::kExistingDirectory:
      return CLI::ExistingDirectory;
  }
  return CLI::Validator();
}

}  // namespace

Option* Option::check(const Validator& validator) {
  option_->check(toCli(validator));
  return this;
}

Option* Option::check(std::function<std::string(const std::string&)> validator) {
  option_->check(std::move(validator));
  return this;
}

Option* Option::capture_default_str() {
  option_->capture_default_str();
  return this;
}

Option* Option::required(bool value) {
  option_->required(value);
  return this;
}

Option* Option::excludes(Option* other) {
  option_->excludes(other->option_);
  return this;
}

Option* Option::delimiter(char value) {
  option_->delimiter(value);
  return this;
}

Option* Option::expected(int value) {
  option_->expected(value);
  return this;
}

Option* Option::allow_extra_args(bool value) {
  option_->allow_extra_args(value);
  return this;
}

std::size_t Option::count() const {
  return option_->count();
}

struct App::Impl {
  Impl(const std::string& description, const std::string& name) : app(description, name) {}
  CLI::App app;
  // The handles given out; a deque keeps their addresses.
  std::deque<Option> options;
};

App::App(const std::string& description, const std::string& name)
    : impl_(std::make_unique<Impl>(description, name)) {}

App::~App() = default;

Option* App::wrap(CLI::Option* option) {
  impl_->options.push_back(Option(option));
  return &impl_->options.back();
}

#define FIELDLINE_CLI_ADD_OPTION(Type)                                                            \
  Option* App::add_option(const std::string& name, Type& value, const std::string& description) { \
    return wrap(impl_->app.add_option(name, value, description));                                 \
  }
FIELDLINE_CLI_ADD_OPTION(int)
FIELDLINE_CLI_ADD_OPTION(unsigned)
FIELDLINE_CLI_ADD_OPTION(std::int64_t)
FIELDLINE_CLI_ADD_OPTION(std::uint64_t)
FIELDLINE_CLI_ADD_OPTION(double)
FIELDLINE_CLI_ADD_OPTION(bool)
FIELDLINE_CLI_ADD_OPTION(std::string)
FIELDLINE_CLI_ADD_OPTION(std::vector<std::string>)
FIELDLINE_CLI_ADD_OPTION(std::vector<int>)
FIELDLINE_CLI_ADD_OPTION(std::vector<double>)
FIELDLINE_CLI_ADD_OPTION(std::optional<int>)
FIELDLINE_CLI_ADD_OPTION(std::optional<double>)
FIELDLINE_CLI_ADD_OPTION(std::optional<std::string>)
#undef FIELDLINE_CLI_ADD_OPTION

Option* App::add_flag(const std::string& name, bool& value, const std::string& description) {
  return wrap(impl_->app.add_flag(name, value, description));
}

Option* App::set_config(const std::string& name, const std::string& default_file,
                        const std::string& description) {
  CLI::Option* option = impl_->app.set_config(name, default_file, description);
  // CLI11 returns no option for an empty name (and replaces an earlier config option).
  if (option == nullptr) throw std::invalid_argument("cli: set_config needs an option name");
  return wrap(option);
}

App* App::footer(const std::string& text) {
  impl_->app.footer(text);
  return this;
}

void App::parse(int argc, char** argv) {
  try {
    impl_->app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    throw ParseError(e.what(), std::current_exception());
  }
}

int App::exit(const ParseError& error) const {
  // A ParseError made elsewhere than parse() may hold no CLI11 error: report it as a bad argument.
  if (!error.cause()) return impl_->app.exit(CLI::ParseError(error.what(), 2));
  try {
    std::rethrow_exception(error.cause());
  } catch (const CLI::Error& e) {
    return impl_->app.exit(e);
  }
}

}  // namespace fieldline::cli
