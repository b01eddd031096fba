#include "circtest/core/progress.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <utility>

#include <fmt/format.h>

#include "circtest/core/numbers.hpp"

namespace circtest {

namespace {

double steady_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The terminal's width in columns, or 80 when it does not say.
std::size_t terminal_columns(std::FILE* stream) {
  winsize size{};
  if (::ioctl(::fileno(stream), TIOCGWINSZ, &size) == 0 && size.ws_col > 0) return size.ws_col;
  return 80;
}

}  // namespace

bool is_terminal(std::FILE* stream) noexcept {
  return stream != nullptr && ::isatty(::fileno(stream)) == 1;
}

double progress_delay_s() noexcept {
  const char* text = std::getenv("CIRCTEST_PROGRESS_AFTER_S");
  if (text == nullptr) return 1.0;
  const auto v = parse_finite(text);
  return v && *v >= 0.0 && *v <= 3600.0 ? *v : 1.0;
}

ProgressLine::ProgressLine(std::FILE* stream, std::string prefix, bool enabled, double start_s,
                           double delay_s, double interval_s)
    : stream_(stream),
      prefix_(std::move(prefix)),
      enabled_(enabled && stream != nullptr),
      start_s_(start_s),
      delay_s_(delay_s),
      interval_s_(interval_s) {}

ProgressLine::~ProgressLine() {
  clear();
}

void ProgressLine::update(double now_s, std::string_view text) {
  if (!enabled_ || now_s - start_s_ < delay_s_) return;
  if (drawn_ && (now_s - last_draw_s_ < interval_s_ || text == last_text_)) return;
  last_text_ = text;
  std::string line = fmt::format("{}: {}", prefix_, text);
  // One screen line: a wrapped line could not be redrawn in place.
  const std::size_t width = terminal_columns(stream_);
  if (line.size() >= width) line.resize(width - 1);
  std::fprintf(stream_, "\r%s\033[K", line.c_str());
  std::fflush(stream_);
  drawn_ = true;
  last_draw_s_ = now_s;
}

void ProgressLine::clear() {
  if (!drawn_) return;
  std::fputs("\r\033[K", stream_);
  std::fflush(stream_);
  drawn_ = false;
}

ProgressTicker::ProgressTicker(std::string prefix, std::FILE* stream)
    : ProgressTicker(std::move(prefix), stream, is_terminal(stream)) {}

ProgressTicker::ProgressTicker(std::string prefix, std::FILE* stream, bool enabled)
    : start_s_(steady_now_s()), line_(stream, std::move(prefix), enabled, start_s_) {
  if (line_.enabled()) thread_ = std::thread([this] { tick(); });
}

ProgressTicker::~ProgressTicker() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  line_.clear();
}

void ProgressTicker::stage(std::string text) {
  std::lock_guard lock(mutex_);
  stage_ = std::move(text);
  draw();  // a new stage shows at once when the line is due
}

void ProgressTicker::draw() {
  const double now = steady_now_s();
  line_.update(now, fmt::format("{} ({:.0f} s)", stage_, now - start_s_));
}

void ProgressTicker::tick() {
  std::unique_lock lock(mutex_);
  while (!wake_.wait_for(lock, std::chrono::milliseconds(100), [this] { return stop_; })) {
    if (!stage_.empty()) draw();
  }
}

}  // namespace circtest
