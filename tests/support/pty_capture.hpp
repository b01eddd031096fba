#pragma once
// A pseudo-terminal for tests of what a program shows only on a terminal: the terminal side
// as a FILE* (or a file descriptor for a child's stderr), and everything written to it
// collected by a reader thread, so that a writer never blocks on a full terminal buffer.
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>

namespace circtest::testing {

class PtyCapture {
 public:
  PtyCapture();  // throws std::runtime_error when no pseudo-terminal can be opened
  ~PtyCapture();
  PtyCapture(const PtyCapture&) = delete;
  PtyCapture& operator=(const PtyCapture&) = delete;

  std::FILE* terminal() const { return terminal_; }  // the side a program writes to
  int terminal_fd() const;
  // Closes the terminal side and returns everything written to it.
  std::string finish();

 private:
  int master_ = -1;
  std::FILE* terminal_ = nullptr;
  std::thread reader_;
  std::mutex mutex_;
  std::string text_;
};

}  // namespace circtest::testing
