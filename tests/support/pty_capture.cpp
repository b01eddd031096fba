#include "pty_capture.hpp"

#include <pty.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>

namespace circtest::testing {

PtyCapture::PtyCapture() {
  int terminal = -1;
  winsize size{};
  size.ws_row = 24;
  size.ws_col = 200;  // wide enough for a status line uncut
  if (::openpty(&master_, &terminal, nullptr, nullptr, &size) != 0) {
    throw std::runtime_error("openpty failed");
  }
  // Bytes as written: no "\n" -> "\r\n".
  termios mode{};
  ::tcgetattr(terminal, &mode);
  ::cfmakeraw(&mode);
  ::tcsetattr(terminal, TCSANOW, &mode);
  terminal_ = ::fdopen(terminal, "w");
  reader_ = std::thread([this] {
    char buffer[4096];
    for (;;) {
      const ssize_t n = ::read(master_, buffer, sizeof buffer);
      if (n <= 0) return;  // EIO once the terminal side is closed
      std::lock_guard lock(mutex_);
      text_.append(buffer, static_cast<std::size_t>(n));
    }
  });
}

PtyCapture::~PtyCapture() {
  finish();
  if (master_ >= 0) ::close(master_);
}

int PtyCapture::terminal_fd() const {
  return ::fileno(terminal_);
}

std::string PtyCapture::finish() {
  if (terminal_ != nullptr) {
    std::fflush(terminal_);
    // What is written reaches the reader before the terminal side closes.
    for (int i = 0; i < 200; ++i) {
      int pending = 0;
      if (::ioctl(master_, FIONREAD, &pending) != 0 || pending == 0) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::fclose(terminal_);
    terminal_ = nullptr;
  }
  if (reader_.joinable()) reader_.join();
  std::lock_guard lock(mutex_);
  return text_;
}

}  // namespace circtest::testing
