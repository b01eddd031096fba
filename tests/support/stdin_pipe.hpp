#pragma once
// Standard input from a pipe for the length of a test: the bytes a thread writes into the
// pipe are what a reader of "-" (or /dev/stdin) sees; the process's own standard input comes
// back when this ends. The writer ignores a reader that gave up (EPIPE).
#include <fcntl.h>
#include <unistd.h>

#include <csignal>
#include <string>
#include <thread>

namespace circtest::testing {

class StdinPipe {
 public:
  explicit StdinPipe(std::string text) {
    std::signal(SIGPIPE, SIG_IGN);
    int fds[2] = {-1, -1};
    if (::pipe(fds) != 0) return;
    saved_ = ::dup(STDIN_FILENO);
    ::dup2(fds[0], STDIN_FILENO);
    ::close(fds[0]);
    writer_ = std::thread([fd = fds[1], text = std::move(text)] {
      std::size_t done = 0;
      while (done < text.size()) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n <= 0) break;
        done += static_cast<std::size_t>(n);
      }
      ::close(fd);
    });
  }
  ~StdinPipe() {
    if (saved_ >= 0) {
      ::dup2(saved_, STDIN_FILENO);  // the reader's end closed: a writer still busy sees EPIPE
      ::close(saved_);
    }
    if (writer_.joinable()) writer_.join();
  }
  StdinPipe(const StdinPipe&) = delete;
  StdinPipe& operator=(const StdinPipe&) = delete;

 private:
  int saved_ = -1;
  std::thread writer_;
};

}  // namespace circtest::testing
