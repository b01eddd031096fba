// The circlog kernel without HAL: the ring, its accounting of lost records, and the
// producer's rules (what is recorded when), in heap memory instead of RTAPI shared memory.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include "circlog_kernel.hpp"

namespace {

namespace circlog = circtest::circlog;

using circlog::Consumer;
using circlog::Producer;
using circlog::RecordHead;

struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};

// A producer and a consumer on one block, with input "pins" the test sets.
class Ring {
 public:
  Ring(int channels, int depth)
      : bytes_(circlog::shared_size(channels, depth)),
        memory_(std::aligned_alloc(64, (bytes_ + 63) / 64 * 64)),
        values_(static_cast<std::size_t>(channels), 0.0),
        pointers_(static_cast<std::size_t>(channels)) {
    for (std::size_t i = 0; i < values_.size(); ++i) pointers_[i] = &values_[i];
    EXPECT_TRUE(producer.init(memory_.get(), bytes_, channels, depth));
    EXPECT_EQ(consumer.attach(memory_.get(), bytes_), circlog::AttachResult::ok);
  }

  void step(bool enable, double segment = 0.0) {
    producer.step(enable, segment, pointers_.data(), 1000000);
  }

  std::vector<std::vector<unsigned char>> read_all() {
    std::vector<std::vector<unsigned char>> out;
    std::vector<unsigned char> buffer(consumer.record_size() * 7);
    for (;;) {
      const std::size_t n = consumer.read(buffer.data(), 7);
      for (std::size_t i = 0; i < n; ++i) {
        auto first = buffer.begin() + static_cast<long>(i * consumer.record_size());
        out.emplace_back(first, first + static_cast<long>(consumer.record_size()));
      }
      if (n == 0) return out;
    }
  }

  static const RecordHead& head(const std::vector<unsigned char>& r) {
    return *reinterpret_cast<const RecordHead*>(r.data());
  }
  static double value(const std::vector<unsigned char>& r, int i) {
    return circlog::record_values(&head(r))[i];
  }

  std::vector<double>& values() { return values_; }
  void* memory() { return memory_.get(); }
  std::size_t bytes() const { return bytes_; }

  Producer producer;
  Consumer consumer;

 private:
  std::size_t bytes_;
  std::unique_ptr<void, FreeDeleter> memory_;
  std::vector<double> values_;
  std::vector<const volatile double*> pointers_;
};

TEST(CirclogKernel, SharedSizeCoversHeaderAndRecords) {
  EXPECT_EQ(circlog::shared_size(8, 100), circlog::header_bytes() + 100 * (24 + 8 * 8));
  EXPECT_EQ(circlog::shared_size(0, 100), 0u);
  EXPECT_EQ(circlog::shared_size(17, 100), 0u);
  EXPECT_EQ(circlog::shared_size(1, 1), 0u);
  EXPECT_EQ(circlog::shared_size(1, circlog::kMaxDepth + 1), 0u);
  EXPECT_GT(circlog::shared_size(16, circlog::kMaxDepth), 0u);
}

TEST(CirclogKernel, SegmentRoundsHalfAwayFromZeroAndSaturates) {
  EXPECT_EQ(circlog::segment_id(0.0), 0);
  EXPECT_EQ(circlog::segment_id(0.49999999999999994), 0);
  EXPECT_EQ(circlog::segment_id(0.5), 1);
  EXPECT_EQ(circlog::segment_id(2.5), 3);
  EXPECT_EQ(circlog::segment_id(2.4999), 2);
  EXPECT_EQ(circlog::segment_id(-0.5), -1);
  EXPECT_EQ(circlog::segment_id(-2.4), -2);
  EXPECT_EQ(circlog::segment_id(std::nan("")), 0);
  EXPECT_EQ(circlog::segment_id(1e12), std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(circlog::segment_id(-1e12), std::numeric_limits<std::int32_t>::min());
  EXPECT_EQ(circlog::segment_id(std::numeric_limits<double>::infinity()),
            std::numeric_limits<std::int32_t>::max());
}

TEST(CirclogKernel, InitRefusesBadArguments) {
  const std::size_t bytes = circlog::shared_size(4, 8);
  std::unique_ptr<void, FreeDeleter> memory(std::aligned_alloc(64, bytes + 64));
  Producer p;
  EXPECT_FALSE(p.init(nullptr, bytes, 4, 8));
  EXPECT_FALSE(p.init(memory.get(), bytes - 1, 4, 8));
  EXPECT_FALSE(p.init(memory.get(), bytes, 0, 8));
  EXPECT_FALSE(p.init(memory.get(), bytes, 4, 1));
  EXPECT_FALSE(p.init(static_cast<char*>(memory.get()) + 8, bytes, 4, 8));
  EXPECT_TRUE(p.init(memory.get(), bytes, 4, 8));
}

TEST(CirclogKernel, AttachValidatesTheHeader) {
  Ring ring(2, 8);
  Consumer c;
  EXPECT_EQ(c.attach(ring.memory(), 16), circlog::AttachResult::too_small);
  EXPECT_EQ(c.attach(ring.memory(), ring.bytes() - 1), circlog::AttachResult::bad_layout);
  auto* h = static_cast<circlog::SharedHeader*>(ring.memory());
  h->version = 99;
  EXPECT_EQ(c.attach(ring.memory(), ring.bytes()), circlog::AttachResult::bad_version);
  h->version = circlog::kLayoutVersion;
  h->depth = 9;
  EXPECT_EQ(c.attach(ring.memory(), ring.bytes()), circlog::AttachResult::bad_layout);
  h->depth = 8;
  h->magic = 0;
  EXPECT_EQ(c.attach(ring.memory(), ring.bytes()), circlog::AttachResult::bad_magic);
}

TEST(CirclogKernel, NothingIsWrittenWithoutAReader) {
  Ring ring(2, 4);
  for (int i = 0; i < 10; ++i) ring.step(true);
  const circlog::Status s = ring.producer.status();
  EXPECT_EQ(s.periods, 10u);
  EXPECT_EQ(s.written, 0u);
  EXPECT_EQ(s.overruns, 0u);
  EXPECT_FALSE(s.reader_attached);
  EXPECT_EQ(ring.consumer.header().enabled.load(), 1u);
}

TEST(CirclogKernel, RecordsEnabledPeriodsAndTheOneWhereEnableFalls) {
  Ring ring(3, 64);
  ASSERT_EQ(ring.consumer.claim(100), 0);
  EXPECT_TRUE(ring.producer.status().reader_attached);
  // periods 0-1 off, 2-4 on (segment 5), 5-6 off, 7-8 on (segment 6), 9 off
  const bool enable[] = {false, false, true, true, true, false, false, true, true, false};
  for (int p = 0; p < 10; ++p) {
    ring.values() = {p * 1.0, -p * 2.0, 0.25};
    ring.step(enable[p], p < 7 ? 5.0 : 6.2);
  }
  const auto records = ring.read_all();
  ASSERT_EQ(records.size(), 7u);
  const std::uint64_t periods[] = {2, 3, 4, 5, 7, 8, 9};
  const std::uint32_t flags[] = {3, 1, 1, 0, 3, 1, 0};
  const std::int32_t segments[] = {5, 5, 5, 5, 6, 6, 6};
  for (std::size_t i = 0; i < records.size(); ++i) {
    const RecordHead& h = Ring::head(records[i]);
    EXPECT_EQ(h.period, periods[i]) << i;
    EXPECT_EQ(h.seq, i) << i;
    EXPECT_EQ(h.flags, flags[i]) << i;
    EXPECT_EQ(h.segment, segments[i]) << i;
    EXPECT_EQ(Ring::value(records[i], 0), static_cast<double>(periods[i]));
    EXPECT_EQ(Ring::value(records[i], 1), -2.0 * static_cast<double>(periods[i]));
    EXPECT_EQ(Ring::value(records[i], 2), 0.25);
  }
  EXPECT_EQ(ring.producer.status().written, 7u);
  EXPECT_EQ(ring.consumer.header().seq_next.load(), 7u);
}

TEST(CirclogKernel, AFullRingCountsOverrunsAndLeavesASeqAndPeriodGap) {
  Ring ring(1, 4);
  ASSERT_EQ(ring.consumer.claim(1), 0);
  for (int p = 0; p < 10; ++p) ring.step(true);
  circlog::Status s = ring.producer.status();
  EXPECT_EQ(s.written, 4u);
  EXPECT_EQ(s.overruns, 6u);
  EXPECT_EQ(s.high_water, 4u);
  auto records = ring.read_all();
  ASSERT_EQ(records.size(), 4u);
  EXPECT_EQ(Ring::head(records[3]).seq, 3u);
  ring.step(true);  // period 10 fits again
  records = ring.read_all();
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(Ring::head(records[0]).seq, 10u);
  EXPECT_EQ(Ring::head(records[0]).period, 10u);
  s = ring.producer.status();
  EXPECT_EQ(s.written + s.overruns, 11u);
}

TEST(CirclogKernel, OneReaderAtATimeAndAFreshRingForEachClaim) {
  Ring ring(1, 16);
  ASSERT_EQ(ring.consumer.claim(100), 0);
  Consumer second;
  ASSERT_EQ(second.attach(ring.memory(), ring.bytes()), circlog::AttachResult::ok);
  EXPECT_EQ(second.claim(200), 100);
  for (int p = 0; p < 5; ++p) ring.step(true);
  ring.consumer.release();
  ring.step(true);  // not written: nobody reads
  EXPECT_EQ(ring.producer.status().written, 5u);
  // The five unread records of the first session are not handed to the next reader.
  ASSERT_EQ(second.claim(200), 0);
  EXPECT_EQ(second.available(), 0u);
  ring.step(true);
  EXPECT_EQ(second.available(), 1u);
}

TEST(CirclogKernel, StealOnlyFromTheNamedReader) {
  Ring ring(1, 16);
  ASSERT_EQ(ring.consumer.claim(100), 0);
  Consumer next;
  ASSERT_EQ(next.attach(ring.memory(), ring.bytes()), circlog::AttachResult::ok);
  EXPECT_FALSE(next.steal(99, 300));
  EXPECT_TRUE(next.steal(100, 300));
  EXPECT_EQ(ring.consumer.header().reader.load(), 300);
}

TEST(CirclogKernel, RecordsSurviveManyWrapsInOrder) {
  Ring ring(2, 5);
  ASSERT_EQ(ring.consumer.claim(1), 0);
  std::vector<unsigned char> buffer(ring.consumer.record_size() * 3);
  std::uint64_t expected = 0;
  for (int p = 0; p < 1000; ++p) {
    ring.values() = {static_cast<double>(p), 0.5 * p};
    ring.step(true);
    if (p % 3 == 2) {  // read 1..3 records at a time, so reads straddle the wrap point
      const std::size_t n = ring.consumer.read(buffer.data(), static_cast<std::size_t>(p % 4));
      for (std::size_t i = 0; i < n; ++i) {
        const auto* h =
            reinterpret_cast<const RecordHead*>(buffer.data() + i * ring.consumer.record_size());
        ASSERT_EQ(h->period, expected);
        ASSERT_EQ(circlog::record_values(h)[0], static_cast<double>(expected));
        ++expected;
      }
    }
    if (ring.consumer.available() == 5) {
      ASSERT_EQ(ring.consumer.read(buffer.data(), 1), 1u);
      ++expected;
    }
  }
  EXPECT_EQ(ring.producer.status().overruns, 0u);
  EXPECT_EQ(ring.producer.status().high_water, 5u);
}

// A producer thread against a reader thread: every record is whole (its values match its
// period), the seq jumps add up to the overrun count, and nothing is read twice.
TEST(CirclogKernel, ConcurrentProducerAndConsumerLoseNothingUnnoticed) {
  constexpr int kChannels = 8;
  constexpr std::uint64_t kPeriods = 400000;
  Ring ring(kChannels, 64);
  ASSERT_EQ(ring.consumer.claim(1), 0);
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t p = 0; p < kPeriods; ++p) {
      for (int c = 0; c < kChannels; ++c) ring.values()[c] = static_cast<double>(p * 10 + c);
      ring.step(true, 1.0);
      if (p % 4096 == 0) std::this_thread::yield();
    }
    done.store(true);
  });
  std::vector<unsigned char> buffer(ring.consumer.record_size() * 16);
  std::uint64_t received = 0, lost = 0, next_seq = 0, last_period = 0;
  bool torn = false, reordered = false;
  auto drain = [&] {
    std::size_t n;
    while ((n = ring.consumer.read(buffer.data(), 16)) > 0) {
      for (std::size_t i = 0; i < n; ++i) {
        const auto* h =
            reinterpret_cast<const RecordHead*>(buffer.data() + i * ring.consumer.record_size());
        const double* v = circlog::record_values(h);
        for (int c = 0; c < kChannels; ++c) {
          if (v[c] != static_cast<double>(h->period * 10 + c)) torn = true;
        }
        if (received > 0 && h->period <= last_period) reordered = true;
        lost += h->seq - next_seq;
        next_seq = h->seq + 1;
        last_period = h->period;
        ++received;
      }
    }
  };
  while (!done.load()) drain();
  producer.join();
  drain();
  EXPECT_FALSE(torn);
  EXPECT_FALSE(reordered);
  const circlog::Status s = ring.producer.status();
  // Records lost after the last one read leave no seq jump behind them (nothing follows):
  // only the producer's counters show those, as the recorder's end-of-run check relies on.
  const std::uint64_t trailing = kPeriods - next_seq;
  EXPECT_EQ(received + lost, next_seq);
  EXPECT_EQ(lost + trailing, s.overruns);
  EXPECT_EQ(received, s.written);
}

}  // namespace
