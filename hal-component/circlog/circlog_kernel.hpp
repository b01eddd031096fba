#pragma once
// The HAL-free heart of circlog: a fixed-size single-producer single-consumer ring of
// records in one block of (shared) memory, the producer run once per servo period and the
// consumer used by circlog-record. Nothing here allocates, throws, locks or calls the OS,
// so the same code runs inside the realtime module, in the recorder and in unit tests.
//
// Memory layout of the block (all offsets fixed at init, see shared_size()):
//   SharedHeader | depth records of record_bytes(channels) bytes
// A record is RecordHead followed by `channels` doubles.
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace circtest::circlog {

inline constexpr std::uint32_t kMagic = 0x47'4c'43'43;  // "CCLG" in memory order
inline constexpr std::uint32_t kLayoutVersion = 1;
inline constexpr int kMaxChannels = 16;
// 16384 records: 16 s of servo periods at 1 kHz (4 s at 4 kHz) that the recorder may stall
// (disk writeback on slow media, a swapped-out page, a busy GUI) before a record is lost;
// about 1.4 MiB with 8 channels, which every LinuxCNC PC has to spare.
inline constexpr int kDefaultDepth = 16384;
inline constexpr int kMinDepth = 2;
inline constexpr int kMaxDepth = 1 << 21;  // 2 Mi records, 304 MiB at 16 channels
// SysV shared-memory key of instance 0 ("CCL" + instance number).
inline constexpr int kShmKeyBase = 0x43434c00;

enum RecordFlags : std::uint32_t {
  kMarker = 1u,    // the enable pin was true in this period
  kRunStart = 2u,  // first period of a run (enable rose)
};

struct RecordHead {
  std::uint64_t period;  // servo periods since the module was loaded
  std::uint64_t seq;     // producer's record number; a jump means records were lost
  std::uint32_t flags;
  std::int32_t segment;  // the segment pin rounded to an integer
};
static_assert(sizeof(RecordHead) == 24);

struct alignas(64) SharedHeader {
  // Written once by the producer before anyone can attach.
  std::uint32_t magic;
  std::uint32_t version;
  std::uint32_t channels;
  std::uint32_t depth;
  std::uint64_t record_bytes;
  std::uint64_t total_bytes;

  // Producer-owned; the consumer only loads them.
  alignas(64) std::atomic<std::uint64_t> head;  // records published so far
  std::atomic<std::uint64_t> periods;           // servo periods run so far
  std::atomic<std::uint64_t> period_ns;         // the thread's period, from the last call
  std::atomic<std::uint64_t> seq_next;          // records attempted while a reader was attached
  std::atomic<std::uint64_t> written;
  std::atomic<std::uint64_t> overruns;    // records dropped because the ring was full
  std::atomic<std::uint64_t> high_water;  // largest ring fill seen, in records
  std::atomic<std::uint32_t> enabled;
  std::atomic<std::int32_t> segment;

  // Consumer-owned (the producer only loads them). tail on its own cache line so the
  // producer's stores do not bounce the consumer's line every period.
  alignas(64) std::atomic<std::uint64_t> tail;
  std::atomic<std::int32_t> reader;  // pid of the attached reader, 0 when none
};
static_assert(std::atomic<std::uint64_t>::is_always_lock_free,
              "the ring is shared between processes: its atomics must be lock-free");
static_assert(std::atomic<std::int32_t>::is_always_lock_free);

constexpr std::size_t record_bytes(int channels) {
  return sizeof(RecordHead) + sizeof(double) * static_cast<std::size_t>(channels);
}
constexpr std::size_t header_bytes() {
  return sizeof(SharedHeader);
}
// Bytes of the shared block for a configuration; 0 if channels or depth is out of range.
std::size_t shared_size(int channels, int depth) noexcept;

// Rounds a segment pin value to the integer stored in records (half away from zero),
// saturating at the int32 range; NaN gives 0.
std::int32_t segment_id(double value) noexcept;

struct Status {
  std::uint64_t periods;
  std::uint64_t written;
  std::uint64_t overruns;
  std::uint64_t high_water;
  bool reader_attached;
};

// Runs in the servo thread. A record is attempted in every period where enable is true
// and in the one period where it falls (with the marker flag clear), so that back-to-back
// runs stay separate for a reader that splits runs on the marker; nothing is written
// while no reader is attached, so a forgotten logger neither fills up nor counts overruns.
class Producer {
 public:
  // Lays the header out in `memory` (bytes >= shared_size(channels, depth), 8-byte
  // aligned at least). Returns false, touching nothing, when an argument is invalid.
  bool init(void* memory, std::size_t bytes, int channels, int depth) noexcept;

  // One servo period. `inputs` points at `channels` values (HAL's float pins).
  void step(bool enable, double segment, const volatile double* const* inputs,
            long period_ns) noexcept;

  Status status() const noexcept;
  int channels() const noexcept { return channels_; }
  int depth() const noexcept { return depth_; }

 private:
  SharedHeader* header_ = nullptr;
  unsigned char* records_ = nullptr;
  std::size_t record_bytes_ = 0;
  int channels_ = 0;
  int depth_ = 0;
  // Private copies of producer-owned counters, so a period does loads from its own memory
  // only and a store for each published value.
  std::uint64_t period_ = 0;
  std::uint64_t head_ = 0;
  std::uint64_t seq_ = 0;
  std::uint64_t written_ = 0;
  std::uint64_t overruns_ = 0;
  std::uint64_t high_water_ = 0;
  std::uint32_t slot_ = 0;  // head_ % depth_, kept incrementally to avoid a division
  bool was_enabled_ = false;
};

enum class AttachResult { ok, too_small, bad_magic, bad_version, bad_layout };
const char* attach_result_text(AttachResult result) noexcept;

// The single consumer. Attaching validates a block written by Producer::init.
class Consumer {
 public:
  AttachResult attach(void* memory, std::size_t bytes) noexcept;

  // Becomes the block's only reader: empties the ring and returns 0, or returns the pid
  // of the reader that already holds it. The producer starts writing after this.
  int claim(std::int32_t pid) noexcept;
  // Takes over from a reader that is known to be dead (its pid no longer exists).
  bool steal(std::int32_t dead_pid, std::int32_t pid) noexcept;
  // Stops the producer from writing; records already in the ring can still be read.
  void release() noexcept;

  // Copies up to max_records records (record_bytes() apart) into out; returns how many.
  std::size_t read(void* out, std::size_t max_records) noexcept;
  std::size_t available() const noexcept;

  const SharedHeader& header() const noexcept { return *header_; }
  int channels() const noexcept { return static_cast<int>(header_->channels); }
  int depth() const noexcept { return static_cast<int>(header_->depth); }
  std::size_t record_size() const noexcept { return record_bytes_; }

 private:
  void take(std::int32_t pid) noexcept;
  SharedHeader* header_ = nullptr;
  const unsigned char* records_ = nullptr;
  std::size_t record_bytes_ = 0;
  std::uint64_t tail_ = 0;
  std::uint32_t slot_ = 0;
};

// The channel values of a record read by Consumer::read.
inline const double* record_values(const RecordHead* record) {
  return reinterpret_cast<const double*>(record + 1);
}

}  // namespace circtest::circlog
