#include "run_pipeline.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include <sys/resource.h>

#include "io/ply_writer.h"
#include "io/stats_json.h"
#include "platform/thread_affinity.h"
#include "sources/open_source.h"

namespace ef::app {

namespace {

// How long the mapping thread waits for a prepared frame before it looks at the stop requests
// again, and how long the front thread waits for a free slot before it looks at its own.
constexpr std::chrono::milliseconds kPoll(200);

void pin_or_warn(int cpu, const char* thread_name) {
  if (cpu < 0) return;
  const std::string why = pin_current_thread_to_cpu(cpu);
  if (!why.empty()) std::fprintf(stderr, "warning: %s thread: %s; it runs unpinned\n", thread_name, why.c_str());
}

// The process's peak resident memory so far, bytes (Linux reports kilobytes).
double peak_rss_bytes() {
  struct rusage u {};
  if (getrusage(RUSAGE_SELF, &u) != 0) return 0;
  return static_cast<double>(u.ru_maxrss) * 1024.0;
}

std::size_t frame_bytes(const Frame& f) {
  return f.color.size() * sizeof(Rgb8) + f.depth.size() * sizeof(float) + f.labels.size() * sizeof(uint8_t);
}

}  // namespace

Result<std::unique_ptr<RunPipeline>> RunPipeline::create(const RunConfig& config, FrameSource& source,
                                                         StageStats& stats) {
  for (const auto& [key, cpu] : {std::pair<const char*, int>{"pipeline.front_cpu", config.front_cpu},
                                 {"pipeline.mapping_cpu", config.mapping_cpu},
                                 {"pipeline.capture_cpu", config.capture_cpu}}) {
    const unsigned cores = std::thread::hardware_concurrency();
    if (cpu >= 0 && cores > 0 && static_cast<unsigned>(cpu) >= cores)
      return error(ErrorCode::kInvalidArgument, std::string(key) + " " + std::to_string(cpu) +
                                                    ": this machine has cores 0.." + std::to_string(cores - 1));
  }
  std::unique_ptr<RunPipeline> p(new RunPipeline(config, source, stats));
  std::error_code ec;
  std::filesystem::create_directories(config.out_dir, ec);
  if (ec)
    return error(ErrorCode::kIoError, "cannot create output folder '" + config.out_dir + "': " + ec.message());

  const SourceInfo& info = source.info();
  const Intrinsics working = info.intrinsics.scaled_to(config.width, config.height);
  if (config.labels) {
    auto sem = RunSemantics::create(config, working, stats);
    if (!sem.ok()) return sem.take_error();
    p->semantics_ = std::move(*sem);
  }
  const std::string trajectory_path = (std::filesystem::path(config.out_dir) / "trajectory.txt").string();
  auto mapping = MappingStage::create(config, working, stats, p->semantics_.get(), trajectory_path);
  if (!mapping.ok()) return mapping.take_error();
  p->mapping_ = std::move(*mapping);
  auto front = FrontStage::create(config, source, p->mapping_->slam(), p->semantics_.get());
  if (!front.ok()) return front.take_error();
  p->front_ = std::move(*front);

  // The slots, each sized once.
  Status slot_status;
  const auto init = [&](PreparedFrame& slot) {
    if (Status s = p->front_->allocate(slot); !s.ok() && slot_status.ok()) slot_status = s;
    p->slot_bytes_ = frame_bytes(slot.working) + (slot.pre ? slot.pre->bytes() : 0) +
                     slot.cnn.probabilities.size() * sizeof(float) + slot.cnn.labels.size();
  };
  if (config.threads == 1) {
    p->single_slot_ = std::make_unique<PreparedFrame>();
    init(*p->single_slot_);
  } else {
    p->prepared_ = std::make_unique<FrameRing<PreparedFrame>>(config.prepared_slots, init);
  }
  if (!slot_status.ok()) return slot_status.error();

  p->c_ = CounterIds{stats.add_counter("camera_lost"),     stats.add_counter("corrupt_frames_dropped"),
                     stats.add_counter("frames_dropped_overload"), stats.add_counter("surfels_created"),
                     stats.add_counter("surfels_removed"), stats.add_counter("surfels_evicted"),
                     stats.add_counter("surfels_refused")};
  return p;
}

RunPipeline::~RunPipeline() = default;

bool RunPipeline::consume(PreparedFrame& slot, RunObserver& observer, RunOutcome& outcome) {
  if (slot.end) {
    if (slot.error) {
      if (is_camera_lost(source_.info(), *slot.error)) {
        // A camera that vanished ends capture like a stop: what was mapped so far is written.
        outcome.camera_lost = true;
        stats_.increment(c_.camera_lost);
        std::fprintf(stderr, "\n%s; capture stopped, writing the outputs of %lld frames\n",
                     slot.error->message.c_str(), static_cast<long long>(mapping_->frames()));
      } else {
        outcome.error = *slot.error;  // the outputs so far are still written
      }
    }
    return false;
  }
  if (Status s = mapping_->step(slot); !s.ok()) {
    outcome.error = s.error();
    return false;
  }
  observer.frame_mapped(*this);
  return true;
}

void RunPipeline::run_one_thread(RunObserver& observer, RunOutcome& outcome) {
  PreparedFrame& slot = *single_slot_;
  while (true) {
    if (!stop_sent_ && observer.stop_requested(*this)) {
      outcome.stopped = true;
      stop_sent_ = true;
      front_->request_stop();  // drains: a live camera's captured frames still come
    }
    const FrontStage::Step step = front_->step(slot);
    if (step == FrontStage::Step::kNothingYet) continue;
    if (!consume(slot, observer, outcome)) return;
  }
}

void RunPipeline::run_two_threads(RunObserver& observer, RunOutcome& outcome) {
  FrameRing<PreparedFrame>& ring = *prepared_;
  std::thread front_thread([this, &ring] {
    pin_or_warn(config_.front_cpu, "front stage");
    while (true) {
      PreparedFrame* slot = ring.acquire_write_waiting(kPoll);
      if (slot == nullptr) {
        if (ring.closed()) return;  // the mapping stage gave up
        continue;
      }
      const FrontStage::Step step = front_->step(*slot);
      if (step == FrontStage::Step::kNothingYet) {
        ring.abort_write();
        continue;
      }
      ring.commit();
      if (step == FrontStage::Step::kEnd) return;
    }
  });
  while (true) {
    if (!stop_sent_ && observer.stop_requested(*this)) {
      outcome.stopped = true;
      stop_sent_ = true;
      front_->request_stop();  // drains: every prepared or captured frame is still mapped
    }
    PreparedFrame* slot = ring.acquire_read(kPoll);
    if (slot == nullptr) continue;  // the front stage always ends with an end slot
    const bool more = consume(*slot, observer, outcome);
    const bool was_end = slot->end;
    ring.release();
    if (!more) {
      if (!was_end) {
        // A mapping error: the front stage stops where it is; frames it prepared are not mapped.
        front_->request_stop();
        ring.close();
      }
      break;
    }
  }
  front_thread.join();
}

RunOutcome RunPipeline::run(RunObserver& observer) {
  RunOutcome outcome;
  const auto start = std::chrono::steady_clock::now();
  pin_or_warn(config_.mapping_cpu, "mapping");
  front_->start_capture();
  if (config_.threads == 1) run_one_thread(observer, outcome);
  else run_two_threads(observer, outcome);
  outcome.frames = mapping_->frames();
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats_.set_counter(c_.dropped_overload, front_->dropped_overload());
  stats_.set_counter(c_.corrupt_dropped, front_->corrupt_dropped());
  const slam::SurfelPoolCounters& pc = mapping_->slam().pool().counters();
  stats_.set_counter(c_.surfels_created, pc.created);
  stats_.set_counter(c_.surfels_removed, pc.removed);
  stats_.set_counter(c_.surfels_evicted, pc.evicted);
  stats_.set_counter(c_.surfels_refused, pc.refused);
  return outcome;
}

OutputFiles RunPipeline::write_outputs(const RunOutcome& outcome) {
  OutputFiles out;
  const std::filesystem::path dir(config_.out_dir);
  out.trajectory = (dir / "trajectory.txt").string();
  out.map = (dir / "map.ply").string();
  out.stats = (dir / "stats.json").string();
  slam::SurfelSlam& slam = mapping_->slam();

  if (Status s = mapping_->close_trajectory(); !s.ok()) out.errors.push_back(s.error());
  else out.wrote_trajectory = true;
  if (semantics_ != nullptr) {
    if (Status s = semantics_->finish(slam); !s.ok()) out.errors.push_back(s.error());
  }
  if (config_.write_map) {
    const std::string comment =
        "edgefusion map of " + config_.source + ", " + std::to_string(outcome.frames) + " frames";
    SurfelCloudView cloud = slam::surfel_cloud_view(slam.pool());
    if (semantics_ != nullptr) semantics_->add_label_columns(slam.pool(), cloud);
    if (Status s = write_surfel_ply(out.map, cloud, comment); !s.ok()) out.errors.push_back(s.error());
    else out.wrote_map = true;
  }
  const std::vector<StatsExtraField> extra = {
      {"width", static_cast<double>(config_.width)},
      {"height", static_cast<double>(config_.height)},
      {"threads", static_cast<double>(config_.threads)},
      {"surfels", static_cast<double>(slam.pool().size())},
      {"surfel_capacity", static_cast<double>(slam.pool().capacity())},
      {"surfel_pool_bytes", static_cast<double>(slam.pool_bytes())},
      {"bytes_per_surfel", static_cast<double>(slam::SurfelPool::kBytesPerSurfel)},
      {"peak_rss_bytes", peak_rss_bytes()}};
  if (Status s = write_stats_json(out.stats, stats_, static_cast<uint64_t>(outcome.frames), outcome.seconds, extra);
      !s.ok())
    out.errors.push_back(s.error());
  else
    out.wrote_stats = true;
  return out;
}

}  // namespace ef::app
