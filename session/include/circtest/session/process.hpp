#pragma once
// The programs a session runs (circgen, circlog-record, circana, circcomp, halcmd, the
// LinuxCNC link): started without a shell, their output to a file or a pipe.
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace circtest::session {

// A started program. Destroyed while running, it is sent SIGTERM and waited for.
class Child {
 public:
  // Starts ARGV (ARGV[0] a path or a name found on PATH). STDOUT_PATH: its standard output
  // goes to that file (created, replaced); "-": the session's own; empty: to a pipe read with
  // read_line(). Standard error stays the session's, or goes to STDERR_PATH when one is given
  // (appended). Throws HalError (exit 7) when it cannot be started.
  Child(const std::vector<std::string>& argv, const std::string& stdout_path,
        const std::string& stderr_path = {});
  ~Child();
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  // The next line of its standard output (pipe only); false at its end.
  bool read_line(std::string& line);
  // The same, waiting at most SECONDS for it: nullopt when no line came in that time.
  std::optional<bool> read_line_for(std::string& line, double seconds);
  // Whether it still runs (reaps it when it has ended).
  bool running();
  void signal(int signo);
  // Waits for its end: the exit code, 128 + signal when killed.
  int wait();
  // Waits up to SECONDS: the exit code, or -1 when it still runs.
  int wait_for(double seconds);
  const std::string& name() const { return name_; }

 private:
  pid_t pid_ = -1;
  int out_fd_ = -1;
  int status_ = -1;
  std::string buffer_;
  std::string name_;
};

// Runs ARGV to its end with its standard output into STDOUT_PATH (empty: the session's own
// standard output); the exit code.
int run_program(const std::vector<std::string>& argv, const std::string& stdout_path = {});

// Runs ARGV and returns its standard output; EXIT_CODE gets its exit code. Its standard error
// goes to STDERR_PATH when one is given, else to the session's.
std::string program_output(const std::vector<std::string>& argv, int& exit_code,
                           const std::string& stderr_path = {});

// The path of the circtest program NAME (circgen, circana, ...): $CIRCTEST_BIN/<part>/NAME in
// a build tree when CIRCTEST_BIN is set, else beside the running circtest, else NAME (PATH).
std::string tool_path(const std::string& name);

}  // namespace circtest::session
