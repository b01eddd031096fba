#include "circtest/session/process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <thread>

#include "circtest/core/error.hpp"

extern char** environ;

namespace circtest::session {

namespace fs = std::filesystem;

Child::Child(const std::vector<std::string>& argv, const std::string& stdout_path,
             const std::string& stderr_path)
    : name_(fs::path(argv.at(0)).filename().string()) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  int pipe_fds[2] = {-1, -1};
  if (stdout_path.empty()) {
    if (::pipe2(pipe_fds, O_CLOEXEC) != 0) throw HalError(name_ + ": cannot make a pipe");
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  } else if (stdout_path != "-") {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, stdout_path.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  if (!stderr_path.empty()) {
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderr_path.c_str(),
                                     O_WRONLY | O_CREAT | O_APPEND, 0644);
  }
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int rc = ::posix_spawnp(&pid_, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (pipe_fds[1] >= 0) ::close(pipe_fds[1]);
  if (rc != 0) {
    if (pipe_fds[0] >= 0) ::close(pipe_fds[0]);
    throw HalError(argv[0] + ": cannot be started: " + std::strerror(rc));
  }
  out_fd_ = pipe_fds[0];
}

Child::~Child() {
  if (out_fd_ >= 0) ::close(out_fd_);
  if (running()) {
    signal(SIGTERM);
    wait();
  }
}

bool Child::read_line(std::string& line) {
  for (;;) {
    if (const auto nl = buffer_.find('\n'); nl != std::string::npos) {
      line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      return true;
    }
    if (out_fd_ < 0) return false;
    char chunk[4096];
    const ssize_t n = ::read(out_fd_, chunk, sizeof chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(out_fd_);
      out_fd_ = -1;
      if (buffer_.empty()) return false;
      line = buffer_;
      buffer_.clear();
      return true;
    }
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
}

std::optional<bool> Child::read_line_for(std::string& line, double seconds) {
  if (buffer_.find('\n') == std::string::npos && out_fd_ >= 0) {
    pollfd p{out_fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(seconds * 1000));
    if (r == 0) return std::nullopt;
  }
  return read_line(line);
}

bool Child::running() {
  if (status_ >= 0 || pid_ < 0) return false;
  int st = 0;
  const pid_t r = ::waitpid(pid_, &st, WNOHANG);
  if (r == 0) return true;
  status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return false;
}

void Child::signal(int signo) {
  if (running()) ::kill(pid_, signo);
}

int Child::wait() {
  if (status_ >= 0 || pid_ < 0) return status_;
  int st = 0;
  while (::waitpid(pid_, &st, 0) < 0) {
    if (errno != EINTR) return status_ = 1;
  }
  return status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

int Child::wait_for(double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (running()) {
    if (std::chrono::steady_clock::now() >= end) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return status_;
}

int run_program(const std::vector<std::string>& argv, const std::string& stdout_path) {
  std::cout.flush();
  Child child(argv, stdout_path.empty() ? "-" : stdout_path);
  return child.wait();
}

std::string program_output(const std::vector<std::string>& argv, int& exit_code,
                           const std::string& stderr_path) {
  Child child(argv, "", stderr_path);
  std::string out, line;
  while (child.read_line(line)) out += line + "\n";
  exit_code = child.wait();
  return out;
}

std::string tool_path(const std::string& name) {
  static const std::map<std::string, std::string> parts = {{"circgen", "gcode-gen"},
                                                           {"circana", "analysis"},
                                                           {"circcomp", "compensation"},
                                                           {"circlog-record", "hal-component"},
                                                           {"circtest-linuxcnc", "session"}};
  if (const char* bin = std::getenv("CIRCTEST_BIN"); bin != nullptr && *bin != '\0') {
    const auto part = parts.find(name);
    if (part != parts.end()) {
      const fs::path p = fs::path(bin) / part->second / name;
      if (fs::exists(p)) return p.string();
    }
  }
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path beside = self.parent_path() / name;
    if (fs::exists(beside, ec)) return beside.string();
    // The installed package keeps the LinuxCNC link under libexec.
    const fs::path libexec = self.parent_path().parent_path() / "libexec/circtest" / name;
    if (fs::exists(libexec, ec)) return libexec.string();
  }
  return name;
}

}  // namespace circtest::session
