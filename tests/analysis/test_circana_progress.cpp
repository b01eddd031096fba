// circana's status line on a real terminal: shown on stderr when it is a pseudo-terminal,
// never in piped output, and the report on stdout is the same either way.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "pty_capture.hpp"
#include "scratch.hpp"

extern char** environ;

namespace {

using circtest::testing::PtyCapture;
using circtest::testing::run_command;
using circtest::testing::ScratchDir;
using circtest::testing::slurp;

// Runs ARGV with stdout into OUT_PATH and stderr on the terminal of PTY; its exit code.
int run_on_terminal(const std::vector<std::string>& argv, const std::string& out_path,
                    const PtyCapture& pty, const std::vector<std::string>& env) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_adddup2(&actions, pty.terminal_fd(), 2);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::vector<std::string> env_text(env);
  for (char** e = environ; *e != nullptr; ++e) env_text.emplace_back(*e);
  std::vector<char*> envp;
  for (auto& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = 0;
  const int spawned =
      posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace

TEST(CircanaProgress, OnATerminalOnlyAndNeverInThePipedReport) {
  ScratchDir dir("circana-progress");
  const std::string trace = dir.file("long.csv");
  ASSERT_EQ(run_command({SIMTRACE_PATH, "-o", trace, "--backlash-x", "0.01"}).exit_code, 0);
  // No delay: each stage's line shows as the stage begins, however short the trace.
  const std::vector<std::string> env = {"CIRCTEST_PROGRESS_AFTER_S=0"};
  for (const std::string command : {"analyze", "diagnose"}) {
    PtyCapture pty;
    const std::string out = dir.file(command + ".out");
    ASSERT_EQ(run_on_terminal({CIRCANA_PATH, command, trace}, out, pty, env), 0);
    const std::string shown = pty.finish();
    EXPECT_NE(shown.find("\rcircana " + command + ": reading and evaluating " + trace + " ("),
              std::string::npos)
        << shown;
    EXPECT_TRUE(shown.ends_with("\r\033[K")) << "the line is gone at the end:\n" << shown;

    // Piped: nothing on stderr, and stdout is the report the terminal run wrote.
    const auto piped = run_command({CIRCANA_PATH, command, trace}, env);
    EXPECT_EQ(piped.exit_code, 0);
    EXPECT_EQ(piped.err, "");
    EXPECT_EQ(piped.out, slurp(out));
    EXPECT_EQ(piped.out.find('\r'), std::string::npos);
  }
  // The export of the same trace and its import back: each with its status line.
  const std::string polar = dir.file("long-polar.txt");
  const std::string imported = dir.file("imported.csv");
  const std::vector<std::vector<std::string>> commands = {
      {CIRCANA_PATH, "export-polar", trace, "-o", polar},
      {CIRCANA_PATH, "import", polar, "-o", imported}};
  for (const auto& argv : commands) {
    PtyCapture pty;
    ASSERT_EQ(run_on_terminal(argv, dir.file("out.txt"), pty, env), 0);
    const std::string shown = pty.finish();
    EXPECT_NE(shown.find("\rcircana " + argv[1] + ": reading "), std::string::npos) << shown;
    EXPECT_TRUE(shown.ends_with("\r\033[K")) << shown;
    EXPECT_EQ(slurp(dir.file("out.txt")).find('\r'), std::string::npos);
  }
}
