#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/frame.h"
#include "core/frame_ring.h"

namespace ef {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

FrameRing<int> int_ring(int capacity) {
  return FrameRing<int>(capacity, [](int& v) { v = -1; });
}

void push(FrameRing<int>& ring, int value) {
  ring.acquire_write() = value;
  ring.commit();
}

// Reads one value (must be available now) and releases its slot.
int pop(FrameRing<int>& ring) {
  int* v = ring.try_acquire_read();
  EXPECT_NE(v, nullptr);
  if (v == nullptr) return -1;
  const int value = *v;
  ring.release();
  return value;
}

TEST(FrameRing, CapacityIsAtLeastTwoAndInitRunsPerSlot) {
  int inits = 0;
  FrameRing<int> ring(1, [&](int& v) { v = 7; ++inits; });
  EXPECT_EQ(ring.capacity(), 2);
  EXPECT_EQ(inits, 2);
  FrameRing<int> ring5(5, [&](int& v) { v = 0; ++inits; });
  EXPECT_EQ(ring5.capacity(), 5);
  EXPECT_EQ(inits, 7);
}

TEST(FrameRing, FifoOrder) {
  FrameRing<int> ring(4, [](int& v) { v = -1; });
  EXPECT_EQ(ring.try_acquire_read(), nullptr);
  for (int round = 0; round < 5; ++round) {  // wraps the internal FIFO several times
    push(ring, 10 * round + 1);
    push(ring, 10 * round + 2);
    push(ring, 10 * round + 3);
    EXPECT_EQ(ring.ready_count(), 3);
    EXPECT_EQ(pop(ring), 10 * round + 1);
    EXPECT_EQ(pop(ring), 10 * round + 2);
    push(ring, 10 * round + 4);
    EXPECT_EQ(pop(ring), 10 * round + 3);
    EXPECT_EQ(pop(ring), 10 * round + 4);
    EXPECT_EQ(ring.try_acquire_read(), nullptr);
  }
  EXPECT_EQ(ring.committed(), 20u);
  EXPECT_EQ(ring.dropped(), 0u);
}

TEST(FrameRing, OverloadDropsTheOldestReadyFrame) {
  FrameRing<int> ring(3, [](int& v) { v = -1; });
  push(ring, 1);
  push(ring, 2);
  push(ring, 3);
  EXPECT_EQ(ring.dropped(), 0u);
  push(ring, 4);  // no free slot: frame 1 goes
  EXPECT_EQ(ring.dropped(), 1u);
  EXPECT_EQ(ring.ready_count(), 3);
  push(ring, 5);  // then frame 2
  EXPECT_EQ(ring.dropped(), 2u);
  EXPECT_EQ(ring.committed(), 5u);
  EXPECT_EQ(pop(ring), 3);
  EXPECT_EQ(pop(ring), 4);
  EXPECT_EQ(pop(ring), 5);
  EXPECT_EQ(ring.try_acquire_read(), nullptr);
  // committed == read + dropped + remaining
  EXPECT_EQ(ring.committed(), 3u + ring.dropped() + static_cast<uint64_t>(ring.ready_count()));
}

TEST(FrameRing, SlotBeingReadIsNeverTakenByTheWriter) {
  for (int capacity : {2, 3, 5}) {
    SCOPED_TRACE(capacity);
    FrameRing<int> ring = int_ring(capacity);
    push(ring, 100);
    int* reading = ring.try_acquire_read();
    ASSERT_NE(reading, nullptr);
    ASSERT_EQ(*reading, 100);
    // Far more writes than slots while the consumer holds its slot.
    for (int i = 0; i < 4 * capacity; ++i) {
      int& w = ring.acquire_write();
      EXPECT_NE(&w, reading) << "writer was handed the slot being read";
      w = i;
      ring.commit();
      EXPECT_EQ(*reading, 100);
    }
    EXPECT_EQ(ring.ready_count(), capacity - 1);
    EXPECT_EQ(ring.dropped(), static_cast<uint64_t>(4 * capacity - (capacity - 1)));
    ring.release();
    // The newest capacity - 1 frames remain, oldest first.
    for (int i = 4 * capacity - (capacity - 1); i < 4 * capacity; ++i) EXPECT_EQ(pop(ring), i);
    EXPECT_EQ(ring.try_acquire_read(), nullptr);
  }
}

TEST(FrameRing, CapacityTwoAlternates) {
  FrameRing<int> ring = int_ring(2);
  for (int i = 0; i < 10; ++i) {
    push(ring, i);
    EXPECT_EQ(pop(ring), i);
  }
  // Producer ahead of a consumer that holds a slot: only the newest frame survives.
  push(ring, 20);
  int* r = ring.try_acquire_read();
  ASSERT_NE(r, nullptr);
  push(ring, 21);
  push(ring, 22);
  push(ring, 23);
  EXPECT_EQ(*r, 20);
  ring.release();
  EXPECT_EQ(pop(ring), 23);
  EXPECT_EQ(ring.dropped(), 2u);
  EXPECT_EQ(ring.committed(), 14u);
}

TEST(FrameRing, AbortWriteReturnsTheSlotUnpublished) {
  FrameRing<int> ring = int_ring(2);
  for (int i = 0; i < 5; ++i) {  // aborting repeatedly must not leak slots
    ring.acquire_write() = 99;
    ring.abort_write();
  }
  EXPECT_EQ(ring.committed(), 0u);
  EXPECT_EQ(ring.try_acquire_read(), nullptr);
  push(ring, 1);
  push(ring, 2);
  EXPECT_EQ(ring.dropped(), 0u) << "aborted slots must be free again";
  EXPECT_EQ(pop(ring), 1);
  EXPECT_EQ(pop(ring), 2);
}

TEST(FrameRing, ReadTimesOutWhenEmpty) {
  FrameRing<int> ring = int_ring(2);
  const auto t0 = Clock::now();
  EXPECT_EQ(ring.acquire_read(milliseconds(30)), nullptr);
  EXPECT_GE(Clock::now() - t0, milliseconds(25));
}

TEST(FrameRing, CloseWakesAWaitingReader) {
  FrameRing<int> ring = int_ring(2);
  std::atomic<bool> returned{false};
  int* got = reinterpret_cast<int*>(1);
  const auto t0 = Clock::now();
  std::thread reader([&] {
    got = ring.acquire_read(std::chrono::seconds(20));
    returned = true;
  });
  std::this_thread::sleep_for(milliseconds(50));
  EXPECT_FALSE(returned.load()) << "reader should be waiting";
  ring.close();
  reader.join();
  EXPECT_EQ(got, nullptr);
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(5)) << "close() did not wake the reader";
  EXPECT_TRUE(ring.closed_and_empty());
}

TEST(FrameRing, CloseStillDeliversReadyFrames) {
  FrameRing<int> ring = int_ring(3);
  push(ring, 1);
  push(ring, 2);
  ring.close();
  EXPECT_FALSE(ring.closed_and_empty());
  EXPECT_EQ(pop(ring), 1);
  EXPECT_EQ(pop(ring), 2);
  EXPECT_TRUE(ring.closed_and_empty());
  const auto t0 = Clock::now();
  EXPECT_EQ(ring.acquire_read(std::chrono::seconds(20)), nullptr);  // closed: no wait
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(5));
}

TEST(FrameRing, CommitWakesAWaitingReader) {
  FrameRing<int> ring = int_ring(2);
  int value = -1;
  std::thread reader([&] {
    if (int* v = ring.acquire_read(std::chrono::seconds(20))) {
      value = *v;
      ring.release();
    }
  });
  std::this_thread::sleep_for(milliseconds(20));
  const auto t0 = Clock::now();
  push(ring, 42);
  reader.join();
  EXPECT_EQ(value, 42);
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(5));
}

TEST(FrameRing, UnboundedTimeoutWaitsInsteadOfReturningAtOnce) {
  // microseconds::max() as "wait forever" must not overflow into an immediate time-out.
  FrameRing<int> ring = int_ring(2);
  int value = -1;
  bool got_null = false;
  std::thread reader([&] {
    int* v = ring.acquire_read(microseconds::max());
    if (v == nullptr) {
      got_null = true;
      return;
    }
    value = *v;
    ring.release();
  });
  std::this_thread::sleep_for(milliseconds(50));
  push(ring, 5);
  reader.join();
  EXPECT_FALSE(got_null) << "acquire_read(max) returned before any frame was committed";
  EXPECT_EQ(value, 5);
}

// ---- multi-threaded stress on real Frames ----

constexpr int kW = 24, kH = 16;

uint32_t mix(uint32_t a) {  // small integer hash
  a ^= a >> 16;
  a *= 0x7feb352dU;
  a ^= a >> 15;
  a *= 0x846ca68bU;
  a ^= a >> 16;
  return a;
}

Rgb8 pixel_color(int64_t seq, int x, int y) {
  const uint32_t h = mix(static_cast<uint32_t>(seq) * 2654435761U + static_cast<uint32_t>(y * kW + x));
  return Rgb8{static_cast<uint8_t>(h), static_cast<uint8_t>(h >> 8), static_cast<uint8_t>(h >> 16)};
}

// Checksum over every pixel and the index, as the producer computed it from what it wrote.
uint32_t frame_checksum(const Frame& f) {
  uint32_t c = mix(static_cast<uint32_t>(f.index));
  for (int y = 0; y < f.color.height(); ++y)
    for (int x = 0; x < f.color.width(); ++x) {
      const Rgb8 p = f.color(x, y);
      uint32_t d;
      static_assert(sizeof(d) == sizeof(float));
      std::memcpy(&d, &f.depth(x, y), sizeof d);
      c = mix(c ^ (uint32_t(p.r) | uint32_t(p.g) << 8 | uint32_t(p.b) << 16) ^ (d * 31U) ^ f.labels(x, y));
    }
  return c;
}

void write_frame(Frame& f, int64_t seq, std::mt19937& rng) {
  f.index = seq;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      f.color(x, y) = pixel_color(seq, x, y);
      f.depth(x, y) = static_cast<float>(seq);  // exact up to 2^24
      f.labels(x, y) = static_cast<uint8_t>(seq + x + y);
    }
    // Occasionally yield mid-frame so a reader that could see the slot would see it half-written.
    if (y == kH / 2 && rng() % 16 == 0) std::this_thread::yield();
  }
  f.has_labels = true;
  f.has_pose = (seq % 2) == 0;
  f.T_wc = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(static_cast<double>(seq), 0, 0));
  char name[32];
  std::snprintf(name, sizeof name, "frame-%06lld", static_cast<long long>(seq));
  f.name.assign(name);
  f.timestamp = static_cast<double>(frame_checksum(f));
}

// Empty string when the frame is internally consistent, else what is wrong.
std::string check_frame(const Frame& f) {
  const int64_t seq = f.index;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      if (f.depth(x, y) != static_cast<float>(seq)) return "depth pixel from another frame";
      if (f.color(x, y) != pixel_color(seq, x, y)) return "colour pixel from another frame";
      if (f.labels(x, y) != static_cast<uint8_t>(seq + x + y)) return "label pixel from another frame";
    }
  char name[32];
  std::snprintf(name, sizeof name, "frame-%06lld", static_cast<long long>(seq));
  if (f.name != name) return "name from another frame";
  if (f.T_wc.translation().x() != static_cast<double>(seq)) return "pose from another frame";
  if (f.has_pose != ((seq % 2) == 0)) return "has_pose from another frame";
  if (f.timestamp != static_cast<double>(frame_checksum(f))) return "checksum mismatch";
  return {};
}

void maybe_sleep(std::mt19937& rng, int percent, int max_us) {
  if (static_cast<int>(rng() % 100) < percent)
    std::this_thread::sleep_for(microseconds(rng() % static_cast<unsigned>(max_us)));
}

TEST(FrameRing, StressProducerConsumerNeverSeesTornFrames) {
  constexpr int kFrames = 3000;
  FrameRing<Frame> ring(3, [](Frame& f) { f.allocate(kW, kH, true); });

  std::vector<uint8_t> committed_seq(kFrames, 0);  // producer-owned until join
  std::vector<int64_t> read_seq;                   // consumer-owned until join
  read_seq.reserve(kFrames);
  std::string consumer_error;
  int64_t aborted = 0;

  std::thread producer([&] {
    std::mt19937 rng(1);
    for (int64_t seq = 0; seq < kFrames; ++seq) {
      Frame& f = ring.acquire_write();
      write_frame(f, seq, rng);
      if (rng() % 50 == 0) {  // a source that failed to deliver
        ring.abort_write();
        ++aborted;
      } else {
        ring.commit();
        committed_seq[seq] = 1;
      }
      // First half: producer faster than the consumer (frames dropped); second half: slower.
      maybe_sleep(rng, seq < kFrames / 2 ? 10 : 60, 80);
    }
    ring.close();
  });

  std::thread consumer([&] {
    std::mt19937 rng(2);
    int64_t last = -1;
    for (;;) {
      const Frame* f = ring.acquire_read(milliseconds(2));
      if (f == nullptr) {
        if (ring.closed_and_empty()) break;
        continue;
      }
      maybe_sleep(rng, 30, 60);  // hold the slot while the producer keeps writing
      std::string err = check_frame(*f);
      if (err.empty() && f->index <= last) err = "sequence did not increase";
      if (!err.empty() && consumer_error.empty())
        consumer_error = err + " at index " + std::to_string(f->index) + " after " + std::to_string(last);
      last = f->index;
      read_seq.push_back(f->index);
      ring.release();
      maybe_sleep(rng, 40, 60);
    }
  });

  producer.join();
  consumer.join();

  EXPECT_EQ(consumer_error, "");
  const uint64_t committed = ring.committed();
  EXPECT_EQ(committed, static_cast<uint64_t>(kFrames - aborted));
  EXPECT_EQ(ring.ready_count(), 0);
  EXPECT_EQ(committed, read_seq.size() + ring.dropped() + static_cast<uint64_t>(ring.ready_count()));
  // Every frame read was committed (never an aborted one), and the committed frames not read are
  // exactly the dropped ones.
  uint64_t read_committed = 0;
  for (int64_t s : read_seq) read_committed += committed_seq.at(static_cast<std::size_t>(s));
  EXPECT_EQ(read_committed, read_seq.size());
  // Both regimes were exercised: frames were dropped and frames were read.
  EXPECT_GT(ring.dropped(), 0u);
  EXPECT_GT(read_seq.size(), static_cast<std::size_t>(kFrames / 4));
}

}  // namespace
}  // namespace ef
