#include "slam/surfel_pool.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <new>
#include <sstream>

namespace ef::slam {

namespace {
constexpr std::size_t kAlign = 64;
constexpr int64_t kMaxCapacity = 100'000'000;
std::size_t round_up(std::size_t n) { return (n + kAlign - 1) & ~(kAlign - 1); }
std::size_t block_count(int64_t capacity) {
  return static_cast<std::size_t>((capacity + SurfelPool::kBoundsBlock - 1) / SurfelPool::kBoundsBlock);
}
}  // namespace

const opt::Table<SurfelPoolOptions>& SurfelPoolOptions::table() {
  static const opt::Table<SurfelPoolOptions> t = {
      {"surfel_capacity", "surfel_capacity", "--surfel-capacity", &SurfelPoolOptions::capacity, "surfels",
       opt::between(1, double(kMaxCapacity)), "surfels in the map's pool, allocated at start-up (60 bytes each)"},
  };
  return t;
}

Status SurfelPoolOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "surfel pool"));
  if (evict_unseen_frames < 1)
    return error(ErrorCode::kInvalidArgument,
                 "surfel pool: evict_unseen_frames " + std::to_string(evict_unseen_frames) + " must be >= 1");
  return Status::success();
}

std::string SurfelPoolOptions::describe() const {
  std::ostringstream s;
  s << "capacity: " << capacity << "  # surfels, " << SurfelPool::kBytesPerSurfel << " bytes each\n"
    << "evict_unseen_frames: " << evict_unseen_frames << "  # frames; surfels unseen this long may be evicted (unstable first)\n";
  return s.str();
}

void SurfelPool::AlignedFree::operator()(unsigned char* p) const { ::operator delete[](p, std::align_val_t(kAlign)); }

std::size_t SurfelPool::bytes_for(int64_t capacity) {
  const auto n = static_cast<std::size_t>(capacity > 0 ? capacity : 0);
  return 8 * round_up(n * sizeof(float)) + 3 * round_up(n * sizeof(uint32_t)) + round_up(n * kLabelBytesPerSurfel) +
         block_count(capacity > 0 ? capacity : 0) * sizeof(BlockBounds);
}

Result<SurfelPool> SurfelPool::create(const SurfelPoolOptions& options) {
  if (Status s = options.validate(); !s.ok()) return s.take_error();
  const auto n = static_cast<std::size_t>(options.capacity);
  const std::size_t f = round_up(n * sizeof(float));
  const std::size_t u = round_up(n * sizeof(uint32_t));
  const std::size_t l = round_up(n * kLabelBytesPerSurfel);
  const std::size_t blocks = block_count(options.capacity);
  const std::size_t total = bytes_for(options.capacity);
  const std::size_t columns = total - blocks * sizeof(BlockBounds);
  SurfelPool pool;
  pool.options_ = options;
  pool.bounds_.reset(new (std::nothrow) BlockBounds[blocks]);
  unsigned char* block =
      pool.bounds_ ? new (std::align_val_t(kAlign), std::nothrow) unsigned char[columns] : nullptr;
  if (block == nullptr)
    return error(ErrorCode::kResourceExhausted, "surfel pool: cannot allocate " + std::to_string(total) +
                                                    " bytes for " + std::to_string(options.capacity) + " surfels");
  pool.block_.reset(block);
  pool.bytes_ = total;
  // Touch every page now: the pool is resident from start-up, as the memory plan says, instead of
  // growing with the map (a board short of memory fails here, not an hour into a run), and the
  // process's resident memory stays flat while mapping. About 20 ms for the default 60 MB.
  std::memset(block, 0, columns);
  for (std::size_t b = 0; b < blocks; ++b) pool.reset_bounds(static_cast<int64_t>(b));
  unsigned char* p = block;
  auto take = [&p](std::size_t bytes) { unsigned char* q = p; p += bytes; return q; };
  pool.x_ = reinterpret_cast<float*>(take(f));
  pool.y_ = reinterpret_cast<float*>(take(f));
  pool.z_ = reinterpret_cast<float*>(take(f));
  pool.nx_ = reinterpret_cast<float*>(take(f));
  pool.ny_ = reinterpret_cast<float*>(take(f));
  pool.nz_ = reinterpret_cast<float*>(take(f));
  pool.radius_ = reinterpret_cast<float*>(take(f));
  pool.confidence_ = reinterpret_cast<float*>(take(f));
  pool.color_ = reinterpret_cast<uint32_t*>(take(u));
  pool.init_time_ = reinterpret_cast<int32_t*>(take(u));
  pool.last_seen_ = reinterpret_cast<int32_t*>(take(u));
  pool.labels_ = take(l);
  return pool;
}

int64_t SurfelPool::append(float px, float py, float pz, float pnx, float pny, float pnz, float pradius,
                           float pconfidence, uint32_t pcolor, int32_t frame) {
  if (size_ >= options_.capacity) {
    ++counters_.refused;
    return -1;
  }
  const int64_t i = size_++;
  x_[i] = px;
  y_[i] = py;
  z_[i] = pz;
  nx_[i] = pnx;
  ny_[i] = pny;
  nz_[i] = pnz;
  radius_[i] = pradius;
  confidence_[i] = pconfidence;
  color_[i] = pcolor;
  init_time_[i] = frame;
  last_seen_[i] = frame;
  std::memset(labels_ + i * kLabelBytesPerSurfel, 0, kLabelBytesPerSurfel);
  if (i % kBoundsBlock == 0) reset_bounds(i / kBoundsBlock);  // the block's surfels are all new
  grow_bounds(i);
  ++counters_.created;
  return i;
}

void SurfelPool::copy_surfel(int64_t from, int64_t to) {
  x_[to] = x_[from];
  y_[to] = y_[from];
  z_[to] = z_[from];
  nx_[to] = nx_[from];
  ny_[to] = ny_[from];
  nz_[to] = nz_[from];
  radius_[to] = radius_[from];
  confidence_[to] = confidence_[from];
  color_[to] = color_[from];
  init_time_[to] = init_time_[from];
  last_seen_[to] = last_seen_[from];
  std::memcpy(labels_ + to * kLabelBytesPerSurfel, labels_ + from * kLabelBytesPerSurfel, kLabelBytesPerSurfel);
  grow_bounds(to);
}

void SurfelPool::reset_bounds(int64_t block) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  bounds_[static_cast<std::size_t>(block)] =
      BlockBounds{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}, std::numeric_limits<int32_t>::max(),
                  std::numeric_limits<int32_t>::min()};
}

void SurfelPool::refresh_bounds() {
  if (bounds_current_) return;
  for (int64_t b = 0; b < blocks(); ++b) reset_bounds(b);
  for (int64_t i = 0; i < size_; ++i) grow_bounds(i);
  bounds_current_ = true;
  ++bounds_refreshes_;
}

namespace {

// Bytes [offset, offset + 4) of every record of `n` records of `record` bytes: record i receives
// those of record old_of_new[i], through scratch (4 n bytes). A 4-byte column is record = 4, offset 0.
// memcpy moves bytes whatever the column's type (floats keep their bit patterns).
void gather_word(unsigned char* base, std::size_t record, std::size_t offset, const int32_t* old_of_new, int64_t n,
                 unsigned char* scratch) {
  constexpr std::size_t kWord = 4;
  for (int64_t i = 0; i < n; ++i)
    std::memcpy(scratch + i * kWord, base + static_cast<std::size_t>(old_of_new[i]) * record + offset, kWord);
  if (record == kWord) {
    std::memcpy(base, scratch, static_cast<std::size_t>(n) * kWord);
    return;
  }
  for (int64_t i = 0; i < n; ++i) std::memcpy(base + i * record + offset, scratch + i * kWord, kWord);
}

}  // namespace

void SurfelPool::permute(const int32_t* old_of_new, unsigned char* scratch) {
  static_assert(sizeof(float) == 4 && sizeof(uint32_t) == 4 && sizeof(int32_t) == 4 && kLabelBytesPerSurfel % 4 == 0);
  void* const columns[] = {x_, y_, z_, nx_, ny_, nz_, radius_, confidence_, color_, init_time_, last_seen_};
  for (void* c : columns) gather_word(static_cast<unsigned char*>(c), 4, 0, old_of_new, size_, scratch);
  for (std::size_t w = 0; w < kLabelBytesPerSurfel; w += 4)
    gather_word(labels_, kLabelBytesPerSurfel, w, old_of_new, size_, scratch);
  bounds_current_ = false;  // every block has new members
  refresh_bounds();
}

void SurfelPool::remove(int64_t id) {
  const int64_t last = size_ - 1;
  if (id != last) copy_surfel(last, id);
  --size_;
  ++counters_.removed;
}

void SurfelPool::evict(int64_t id) {
  remove(id);
  --counters_.removed;
  ++counters_.evicted;
}

int64_t SurfelPool::remove_flagged(const uint8_t* flags) {
  int64_t out = 0;
  for (int64_t i = 0; i < size_; ++i) {
    if (flags[i]) continue;
    if (out != i) copy_surfel(i, out);
    ++out;
  }
  const int64_t removed = size_ - out;
  size_ = out;
  if (removed > 0) {
    bounds_current_ = false;  // surfels moved down into other blocks: the bounds are recomputed
    refresh_bounds();
  }
  counters_.removed += static_cast<uint64_t>(removed);
  return removed;
}

int64_t SurfelPool::reserve_for_new(int64_t wanted, int32_t frame, float stable_confidence) {
  if (wanted <= 0) return 0;
  const int64_t room = options_.capacity - size_;
  if (room >= wanted) return wanted;
  const int64_t needed = wanted - room;

  // Eviction order by one key (higher goes first): every unstable candidate before every stable one,
  // the oldest (frames since last seen, capped) first within each. Without sorting: a histogram of
  // the keys, then the smallest key threshold that yields `needed` candidates. Fixed-size, no
  // allocation.
  constexpr int kAges = 1024;
  constexpr int kKeys = 2 * kAges;
  uint32_t histogram[kKeys] = {};
  const int32_t min_age = options_.evict_unseen_frames;
  auto key = [&](int64_t i) {
    const int64_t age = static_cast<int64_t>(frame) - last_seen_[i];
    if (age < min_age) return -1;  // seen recently: what tracking and fusion need now
    return static_cast<int>(std::min<int64_t>(age, kAges - 1)) + (confidence_[i] < stable_confidence ? kAges : 0);
  };
  int64_t candidates = 0;
  for (int64_t i = 0; i < size_; ++i) {
    const int k = key(i);
    if (k < 0) continue;
    ++histogram[k];
    ++candidates;
  }
  if (candidates == 0) return room;
  int threshold = kKeys - 1;
  int64_t above = 0;
  for (; threshold > 0; --threshold) {
    above += histogram[threshold];
    if (above >= needed) break;
  }

  // Evict from high ids to low so that the surfel moved into a freed slot was already visited. Two
  // passes: first every candidate strictly above the threshold key (fewer than `needed`, so all of
  // them go), then threshold-key ones until `needed`; a single pass in id order could spend the
  // quota on threshold-key surfels with high ids and keep older ones with low ids.
  int64_t evicted = 0;
  for (int pass = 0; pass < 2; ++pass) {
    const int min_key = pass == 0 ? threshold + 1 : threshold;
    for (int64_t i = size_ - 1; i >= 0 && evicted < needed; --i) {
      if (key(i) < min_key) continue;
      evict(i);
      ++evicted;
    }
  }
  return room + evicted;
}

Status SurfelPool::set_restored(int64_t size, const SurfelPoolCounters& counters) {
  if (size < 0 || size > options_.capacity)
    return error(ErrorCode::kInvalidArgument, "surfel pool: a checkpoint of " + std::to_string(size) +
                                                  " surfels does not fit a pool of " +
                                                  std::to_string(options_.capacity) +
                                                  " (mapping.surfel_capacity must be at least the checkpoint's)");
  size_ = size;
  counters_ = counters;
  bounds_current_ = false;  // the columns were written by the caller
  refresh_bounds();
  return Status::success();
}

}  // namespace ef::slam
