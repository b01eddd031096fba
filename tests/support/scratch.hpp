#pragma once
// Files and processes for the test suites: a private scratch folder, whole-file reads and
// writes, and running a program (no shell) with its output captured.
#include <filesystem>
#include <string>
#include <vector>

namespace circtest::testing {

// A private folder under the temp directory, removed with its contents on destruction.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& prefix = "circtest-test");
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::string& path() const { return path_; }
  std::filesystem::path dir() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  // Writes (replaces) the file NAME in the folder; its path.
  std::string write(const std::string& name, const std::string& text) const;
  // The whole file NAME of the folder; throws std::runtime_error when it cannot be read.
  std::string read(const std::string& name) const;
  // Leave the folder for a post-mortem (a failed test's logs).
  void keep() { keep_ = true; }

 private:
  std::string path_;
  bool keep_ = false;
};

// The whole file; throws std::runtime_error when it cannot be read.
std::string slurp(const std::filesystem::path& path);
// The whole file, or "" when there is none (for failure messages).
std::string slurp_if_exists(const std::filesystem::path& path);
// Writes (replaces) the whole file; throws std::runtime_error on failure.
void spit(const std::filesystem::path& path, const std::string& text);

// The blank-separated words of a command line (for tests whose paths have no blanks).
std::vector<std::string> words(const std::string& text);

struct CommandResult {
  int exit_code = -1;  // 128 + signal when killed
  std::string out;
  std::string err;
};

// Runs argv (no shell; argv[0] a path) with extra "KEY=value" environment entries, stdin from
// /dev/null, capturing stdout and stderr. With STDOUT_TO (e.g. "/dev/full") standard output
// goes to that existing file instead and CommandResult::out stays empty.
CommandResult run_command(const std::vector<std::string>& argv,
                          const std::vector<std::string>& env = {},
                          const std::string& stdout_to = {});

// Runs a shell command line (redirections and all); its exit code, -1 when it did not exit.
int run_shell(const std::string& command_line);

}  // namespace circtest::testing
