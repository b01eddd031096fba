#pragma once
// The fixture of the circana CLI tests (test_circana_cli.cpp, test_circana_cli_inputs.cpp,
// test_uncertainty_cli.cpp): circana and circtest-simtrace run as a user runs them, in a
// scratch folder.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

#include "circtest/core/strings.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;

namespace {

using circtest::testing::CommandResult;
using circtest::testing::run_command;

using circtest::testing::words;

class CircanaCli : public ::testing::Test {
 protected:
  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    circtest::testing::spit(p, text);
    return p.string();
  }

  CommandResult run(const std::string& args) { return run(words(args)); }
  // circana ARGS expected to succeed, its standard output as JSON (null, the failure reported,
  // when it does not).
  nlohmann::json run_json(const std::string& args) {
    const CommandResult r = run(args);
    EXPECT_EQ(r.exit_code, 0) << args << ": " << r.err;
    return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json();
  }
  CommandResult run(const std::vector<std::string>& args) {
    std::vector<std::string> argv{CIRCANA_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_command(argv);
  }

  static int simtrace(const std::string& args) {
    std::vector<std::string> argv{SIMTRACE_PATH};
    for (auto& w : words(args)) argv.push_back(std::move(w));
    return run_command(argv).exit_code;
  }

  // A bad input: the given exit code, exactly one line on stderr, nothing on stdout.
  void expect_error(const std::string& args, int code, const std::string& message) {
    expect_error(words(args), code, message);
  }
  void expect_error(const std::vector<std::string>& args, int code, const std::string& message) {
    const CommandResult r = run(args);
    const std::string shown = circtest::join(args, " ");
    EXPECT_EQ(r.exit_code, code) << shown << "\n" << r.err;
    EXPECT_EQ(r.out, "") << shown;
    EXPECT_EQ(r.err, "circana: error: " + message + "\n") << shown;
  }

  circtest::testing::ScratchDir scratch_{"circana-cli"};
  fs::path dir_ = scratch_.dir();
};

}  // namespace
