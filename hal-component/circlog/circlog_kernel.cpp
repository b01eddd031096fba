#include "circlog_kernel.hpp"

#include <cstring>
#include <new>

namespace circtest::circlog {

namespace {

constexpr auto mo_relaxed = std::memory_order_relaxed;
constexpr auto mo_acquire = std::memory_order_acquire;
constexpr auto mo_release = std::memory_order_release;

bool valid_config(int channels, int depth) {
  return channels >= 1 && channels <= kMaxChannels && depth >= kMinDepth && depth <= kMaxDepth;
}

}  // namespace

std::size_t shared_size(int channels, int depth) noexcept {
  if (!valid_config(channels, depth)) return 0;
  return header_bytes() + record_bytes(channels) * static_cast<std::size_t>(depth);
}

std::int32_t segment_id(double value) noexcept {
  if (!(value == value)) return 0;  // NaN
  if (value >= 2147483647.0) return 2147483647;
  if (value <= -2147483648.0) return -2147483647 - 1;
  // Truncate, then round on the exact fraction: adding 0.5 first would round
  // 0.49999999999999994 up.
  auto whole = static_cast<std::int32_t>(value);
  const double fraction = value - static_cast<double>(whole);
  if (fraction >= 0.5) ++whole;
  if (fraction <= -0.5) --whole;
  return whole;
}

bool Producer::init(void* memory, std::size_t bytes, int channels, int depth) noexcept {
  const std::size_t need = shared_size(channels, depth);
  if (memory == nullptr || need == 0 || bytes < need ||
      reinterpret_cast<std::uintptr_t>(memory) % alignof(SharedHeader) != 0) {
    return false;
  }
  header_ = new (memory) SharedHeader{};
  records_ = static_cast<unsigned char*>(memory) + header_bytes();
  record_bytes_ = record_bytes(channels);
  channels_ = channels;
  depth_ = depth;
  period_ = head_ = seq_ = written_ = overruns_ = high_water_ = 0;
  slot_ = 0;
  was_enabled_ = false;

  SharedHeader& h = *header_;
  h.version = kLayoutVersion;
  h.channels = static_cast<std::uint32_t>(channels);
  h.depth = static_cast<std::uint32_t>(depth);
  h.record_bytes = record_bytes_;
  h.total_bytes = need;
  // The magic last: a consumer that sees it sees a complete header.
  std::atomic_thread_fence(mo_release);
  h.magic = kMagic;
  return true;
}

void Producer::step(bool enable, double segment, const volatile double* const* inputs,
                    long period_ns) noexcept {
  SharedHeader& h = *header_;
  const std::uint64_t period = period_++;
  const std::int32_t segment_value = segment_id(segment);
  h.periods.store(period_, mo_relaxed);
  h.period_ns.store(period_ns > 0 ? static_cast<std::uint64_t>(period_ns) : 0, mo_relaxed);
  h.enabled.store(enable ? 1u : 0u, mo_relaxed);
  h.segment.store(segment_value, mo_relaxed);

  const bool starting = enable && !was_enabled_;
  const bool closing = !enable && was_enabled_;
  was_enabled_ = enable;
  if (!enable && !closing) return;
  // Negative values mark a reader that is still emptying the ring in claim().
  if (h.reader.load(mo_acquire) <= 0) return;

  const std::uint64_t seq = seq_++;
  h.seq_next.store(seq_, mo_relaxed);
  const std::uint64_t fill = head_ - h.tail.load(mo_acquire);
  if (fill >= static_cast<std::uint64_t>(depth_)) {
    h.overruns.store(++overruns_, mo_relaxed);
    return;
  }

  unsigned char* slot = records_ + static_cast<std::size_t>(slot_) * record_bytes_;
  auto* record = reinterpret_cast<RecordHead*>(slot);
  record->period = period;
  record->seq = seq;
  record->flags = (enable ? kMarker : 0u) | (starting ? kRunStart : 0u);
  record->segment = segment_value;
  auto* values = reinterpret_cast<double*>(record + 1);
  for (int i = 0; i < channels_; ++i) values[i] = *inputs[i];

  ++head_;
  if (++slot_ == static_cast<std::uint32_t>(depth_)) slot_ = 0;
  h.head.store(head_, mo_release);
  h.written.store(++written_, mo_relaxed);
  if (fill + 1 > high_water_) {
    high_water_ = fill + 1;
    h.high_water.store(high_water_, mo_relaxed);
  }
}

Status Producer::status() const noexcept {
  return Status{period_, written_, overruns_, high_water_, header_->reader.load(mo_relaxed) > 0};
}

const char* attach_result_text(AttachResult result) noexcept {
  switch (result) {
    case AttachResult::ok:
      return "ok";
    case AttachResult::too_small:
      return "the shared block is smaller than its header";
    case AttachResult::bad_magic:
      return "the shared block is not a circlog ring";
    case AttachResult::bad_version:
      return "the circlog module and the recorder are from different versions";
    case AttachResult::bad_layout:
      return "the ring's header is inconsistent";
  }
  return "unknown";
}

AttachResult Consumer::attach(void* memory, std::size_t bytes) noexcept {
  if (memory == nullptr || bytes < header_bytes()) return AttachResult::too_small;
  auto* h = static_cast<SharedHeader*>(memory);
  if (h->magic != kMagic) return AttachResult::bad_magic;
  std::atomic_thread_fence(mo_acquire);
  if (h->version != kLayoutVersion) return AttachResult::bad_version;
  const int channels = static_cast<int>(h->channels);
  const int depth = static_cast<int>(h->depth);
  const std::size_t need = shared_size(channels, depth);
  if (need == 0 || h->record_bytes != record_bytes(channels) || h->total_bytes != need ||
      bytes < need) {
    return AttachResult::bad_layout;
  }
  header_ = h;
  records_ = static_cast<const unsigned char*>(memory) + header_bytes();
  record_bytes_ = record_bytes(channels);
  return AttachResult::ok;
}

int Consumer::claim(std::int32_t pid) noexcept {
  std::int32_t expected = 0;
  if (!header_->reader.compare_exchange_strong(expected, -pid, mo_acquire)) return expected;
  take(pid);
  return 0;
}

bool Consumer::steal(std::int32_t dead_pid, std::int32_t pid) noexcept {
  std::int32_t expected = dead_pid;
  if (!header_->reader.compare_exchange_strong(expected, -pid, mo_acquire)) return false;
  take(pid);
  return true;
}

void Consumer::take(std::int32_t pid) noexcept {
  // The producer does not write while reader <= 0, so head is stable here: start with an
  // empty ring instead of a previous session's leftovers.
  tail_ = header_->head.load(mo_acquire);
  slot_ = static_cast<std::uint32_t>(tail_ % header_->depth);
  header_->tail.store(tail_, mo_release);
  header_->reader.store(pid, mo_release);
}

void Consumer::release() noexcept {
  header_->reader.store(0, mo_release);
}

std::size_t Consumer::available() const noexcept {
  return static_cast<std::size_t>(header_->head.load(mo_acquire) - tail_);
}

std::size_t Consumer::read(void* out, std::size_t max_records) noexcept {
  std::size_t n = available();
  if (n > max_records) n = max_records;
  auto* dst = static_cast<unsigned char*>(out);
  const std::uint32_t depth = header_->depth;
  std::size_t left = n;
  while (left > 0) {
    std::size_t chunk = depth - slot_;
    if (chunk > left) chunk = left;
    const unsigned char* src = records_ + static_cast<std::size_t>(slot_) * record_bytes_;
    const std::size_t bytes = chunk * record_bytes_;
    std::memcpy(dst, src, bytes);
    dst += bytes;
    left -= chunk;
    slot_ = static_cast<std::uint32_t>((slot_ + chunk) % depth);
  }
  tail_ += n;
  header_->tail.store(tail_, mo_release);
  return n;
}

}  // namespace circtest::circlog
