#include "pipeline/run_pipeline.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <thread>

#include <sys/resource.h>

#include "core/classes.h"
#include "eval/trajectory_eval.h"
#include "io/ply_writer.h"
#include "io/trajectory_io.h"
#include "io/stats_json.h"
#include "pipeline/checkpoint.h"
#include "pipeline/map_preview.h"
#include "pipeline/memory_plan.h"
#include "pipeline/run_folder.h"
#include "platform/cpu/thread_affinity.h"
#include "sources/open_source.h"

namespace ef::pipeline {

namespace {

// How long the mapping thread waits for a prepared frame before it looks at the stop requests
// again, and how long the front thread waits for a free slot before it looks at its own.
constexpr std::chrono::milliseconds kPoll(200);

// The steps every prepared slot passes through, in order (StageRing stages). The CNN is beside
// them (pipeline/cnn_worker.h).
constexpr int kFront = 0, kMapping = 1, kStages = 2;

// The process's peak resident memory so far, bytes (Linux reports kilobytes).
double peak_rss_bytes() {
  struct rusage u {};
  if (getrusage(RUSAGE_SELF, &u) != 0) return 0;
  return static_cast<double>(u.ru_maxrss) * 1024.0;
}

}  // namespace

RunConfig RunPipeline::resolved(const RunConfig& config) {
  RunConfig c = config;
  c.pipeline = config.pipeline.pinned_for(usable_cpu_cores());
  return c;
}

Result<std::unique_ptr<RunPipeline>> RunPipeline::create(const RunConfig& config, FrameSource& source,
                                                         StageStats& stats) {
  EF_RETURN_IF_ERROR(config.validate());
  EF_RETURN_IF_ERROR(check_run(config, probe_of(source)));
  std::unique_ptr<RunPipeline> p(new RunPipeline(config, source, stats));

  const SourceInfo& info = source.info();
  const Intrinsics working = info.intrinsics.scaled_to(config.run.resolution.width, config.run.resolution.height);
  if (config.labels.enabled) {
    // The CRF's capacity as the memory plan derives it (crf.capacity 0: what the budget leaves).
    int64_t crf_nodes = 0;
    if (config.crf.on()) {
      auto plan = plan_memory(config, probe_of(source));
      if (!plan.ok()) return plan.take_error();
      crf_nodes = plan->crf_nodes;
    }
    auto sem = RunSemantics::create(semantics_options(config, crf_nodes), working, stats);
    if (!sem.ok()) return sem.take_error();
    p->semantics_ = std::move(*sem);
  }
  // The folder once the model loaded: a run that cannot start leaves no empty run folder behind.
  auto folder = prepare_out_folder(config.run, config.output, std::time(nullptr));
  if (!folder.ok()) return folder.take_error();
  p->out_folder_ = std::move(*folder);
  const std::filesystem::path out(p->out_folder_);
  // A new run that cannot start (a log that cannot be created, a source shorter than asked...)
  // leaves none of its outputs behind, so that the folder does not read as holding a run and the
  // same command works once the fault is fixed. A resumed run's folder keeps what it had.
  struct RemoveOnFailure {
    std::vector<std::filesystem::path> files;
    bool armed = true;
    ~RemoveOnFailure() {
      std::error_code ec;
      if (armed)
        for (const auto& f : files) std::filesystem::remove(f, ec);
    }
  } undo;
  if (!config.output.resume)
    undo.files = {out / "trajectory.txt", out / "config.yaml", out / "stats.json", out / ".stats.json.next"};
  // A resumed run: its newest valid checkpoint, and the trajectory cut back to the lines it covers.
  std::optional<FoundCheckpoint> checkpoint;
  if (config.output.resume) {
    auto found = find_checkpoint(p->out_folder_);
    if (!found.ok()) return found.take_error();
    checkpoint = std::move(*found);
    const CheckpointMeta& m = checkpoint->meta;
    if (m.width != config.run.resolution.width || m.height != config.run.resolution.height)
      return error(ErrorCode::kInvalidArgument,
                   checkpoint->reader->path() + ": mapped at " + std::to_string(m.width) + "x" +
                       std::to_string(m.height) + "; this run's resolution is " +
                       std::to_string(config.run.resolution.width) + "x" + std::to_string(config.run.resolution.height));
    p->resumed_ = m;
  }
  const std::string trajectory_path = (out / "trajectory.txt").string();
  auto mapping = MappingStage::create(config.mapping, working, stats, p->semantics_.get(), trajectory_path,
                                      config.output.sync_seconds,
                                      checkpoint ? checkpoint->meta.trajectory_bytes : int64_t{-1});
  if (!mapping.ok()) return mapping.take_error();
  p->mapping_ = std::move(*mapping);
  auto front = FrontStage::create(config.run, p->config_.pipeline, source, p->mapping_->slam(), p->semantics_.get());
  if (!front.ok()) return front.take_error();
  p->front_ = std::move(*front);
  if (!config.log.file.empty()) {
    // The field log of the source's own frames (io/mcap_log.h).
    p->log_path_ = log_path_for(config.log.file, p->out_folder_, checkpoint ? checkpoint->meta.frames : -1);
    std::error_code ec;
    if (!config.output.overwrite && !checkpoint && std::filesystem::exists(p->log_path_, ec))
      return error(ErrorCode::kInvalidArgument, p->log_path_ + ": a log is there already (never overwritten; give "
                                                               "another log.file, or output.overwrite)");
    p->log_ = std::make_unique<McapFrameLog>();
    undo.files.push_back(p->log_path_);
    EF_RETURN_IF_ERROR(p->log_->open(p->log_path_, config.log, info.intrinsics.width, info.intrinsics.height,
                                     info.intrinsics));
    // The mapping thread's: poses and lines, and the CNN's class ids at the working size.
    p->log_encoder_ = p->log_->make_encoder(/*with_images=*/p->semantics_ != nullptr, config.run.resolution.width,
                                            config.run.resolution.height);
    if (p->semantics_ != nullptr) p->semantics_->set_log(p->log_.get(), p->log_encoder_.get());
    p->front_->set_log(p->log_.get());
    p->mapping_->set_log(p->log_.get(), p->log_encoder_.get());
    std::string start = "edgefusion run: mapping " + config.run.source + " at " +
                        std::to_string(config.run.resolution.width) + "x" + std::to_string(config.run.resolution.height);
    if (checkpoint) start += ", resumed after frame " + std::to_string(checkpoint->meta.frames);
    (void)p->log_->log_text(0, foxglove::LogLevel::kInfo, start, *p->log_encoder_);
  }
  if (p->semantics_ != nullptr) {
    const bool threaded = config.pipeline.threads >= 2;
    auto cnn = CnnWorker::create(*p->semantics_, config.run.resolution.width, config.run.resolution.height, threaded,
                                 config.pipeline.test_cnn_delay_ms);
    if (!cnn.ok()) return cnn.take_error();
    p->cnn_ = std::move(*cnn);
    p->front_->set_cnn(p->cnn_.get(), /*deterministic=*/config.pipeline.deterministic || !threaded);
    p->mapping_->set_cnn(p->cnn_.get());
  }

  // The slots, each sized once; one when a single thread takes every step in turn.
  Status slot_status;
  const auto init = [&](PreparedFrame& slot) {
    if (Status s = p->front_->allocate(slot); !s.ok() && slot_status.ok()) slot_status = s;
    p->slot_bytes_ = slot.bytes();
  };
  p->ring_ = std::make_unique<StageRing<PreparedFrame>>(config.pipeline.slots(), kStages, init);
  if (!slot_status.ok()) return slot_status.error();

  p->c_ = CounterIds{stats.add_counter("camera_lost"),     stats.add_counter("corrupt_frames_dropped"),
                     stats.add_counter("frames_dropped_overload"), stats.add_counter("surfels_created"),
                     stats.add_counter("surfels_removed"), stats.add_counter("surfels_evicted"),
                     stats.add_counter("surfels_refused"), stats.add_counter("cnn_frames_skipped"),
                     stats.add_counter("realtime_frames_late"), stats.add_counter("checkpoint_previews_failed")};
  p->st_checkpoint_ = stats.add_stage(kStageNames[0]);
  p->st_log_map_ = stats.add_stage(kStageNames[1]);
  p->st_checkpoint_preview_ = stats.add_stage(kStageNames[2]);
  if (config.run.preview || config.run.report) {
    auto previewer = MapPreviewer::create(kPreviewWidth, kPreviewHeight);
    if (!previewer.ok()) return previewer.take_error();
    p->previewer_ = std::move(*previewer);
    p->preview_path_.reserve(kPreviewPathPoses);
  }

  if (checkpoint) {
    EF_RETURN_IF_ERROR(restore_checkpoint(*checkpoint, p->mapping_->slam(), stats));
    // The path so far, for the checkpoints' previews: the trajectory as cut back to the checkpoint,
    // sampled as the uninterrupted run's path would be (a path that cannot be read stays empty: the
    // picture is drawn without it).
    if (p->previewer_ != nullptr) (void)p->preview_path_.add_file(trajectory_path);
    p->mapping_->resume_at(checkpoint->meta.frames);
    EF_RETURN_IF_ERROR(p->front_->resume_at(checkpoint->meta.frames));
    p->resume_warning_ = checkpoint->warning;
  } else {
    // The configuration beside the outputs: what `run --resume` continues with.
    const std::string text = config.describe();
    EF_RETURN_IF_ERROR(write_file_whole((out / "config.yaml").string(), {{text.data(), text.size()}}));
  }

  // stats.json from the start, so that a run killed at any moment leaves one that says "running".
  // Its text's room is reserved now (a few kB; 64 kB holds 32 stages and 64 counters).
  p->stats_json_.reserve(64 * 1024);
  p->rate_.reserve(kRateSamples);
  p->reference_.reserve(kReferencePoses);
  // In the order of the StatsExtra indices (run_pipeline.h).
  p->stats_extra_ = {{"width", static_cast<double>(config.run.resolution.width)},
                     {"height", static_cast<double>(config.run.resolution.height)},
                     {"threads", static_cast<double>(config.pipeline.threads)},
                     {"surfels", 0},
                     {"surfel_capacity", static_cast<double>(p->mapping_->slam().pool().capacity())},
                     {"surfel_pool_bytes", static_cast<double>(p->mapping_->slam().pool_bytes())},
                     {"bytes_per_surfel", static_cast<double>(slam::SurfelPool::kBytesPerSurfel)},
                     {"peak_rss_bytes", 0},
                     {"resumed_at_frame", p->resumed_ ? static_cast<double>(p->resumed_->frames) : 0.0},
                     {"checkpoints", 0}};
  p->stats_file_.open((out / "stats.json").string());
  EF_RETURN_IF_ERROR(p->write_stats("running", 0, 0.0));
  undo.armed = false;
  return p;
}

void RunPipeline::update_counters() {
  stats_.set_counter(c_.dropped_overload, front_->dropped_overload());
  stats_.set_counter(c_.corrupt_dropped, front_->corrupt_dropped());
  if (cnn_ != nullptr) stats_.set_counter(c_.cnn_skipped, front_->cnn_skipped());
  stats_.set_counter(c_.realtime_late, front_->realtime_late_frames());
  const slam::SurfelPoolCounters& pc = mapping_->slam().pool().counters();
  stats_.set_counter(c_.surfels_created, pc.created);
  stats_.set_counter(c_.surfels_removed, pc.removed);
  stats_.set_counter(c_.surfels_evicted, pc.evicted);
  stats_.set_counter(c_.surfels_refused, pc.refused);
}

Status RunPipeline::write_stats(const char* state, int64_t frames, double seconds) {
  stats_extra_[kExtraSurfels].value = static_cast<double>(mapping_->slam().pool().size());
  stats_extra_[kExtraPeakRss].value = peak_rss_bytes();
  write_stats_object(stats_json_, stats_, static_cast<uint64_t>(frames), seconds, stats_extra_, state);
  return stats_file_.write(stats_json_.str());
}

std::string RunPipeline::log_path_for(const std::string& file, const std::string& folder, int64_t resumed_at) {
  std::filesystem::path p(file);
  if (p.is_relative()) p = std::filesystem::path(folder) / p;
  if (resumed_at < 0) return p.string();
  char suffix[32];
  std::snprintf(suffix, sizeof suffix, ".resume-%06lld", static_cast<long long>(resumed_at));
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

Status RunPipeline::checkpoint(double seconds, bool with_preview) {
  if (mapping_->frames() == 0) return Status::success();
  // The field log's open chunk out with it: the log is readable up to the checkpoint's frames. A
  // log that fails does not stop the checkpoint (its error is reported with the outputs).
  if (log_ != nullptr) (void)log_->flush();
  const auto t0 = std::chrono::steady_clock::now();
  // The trajectory's lines of the frames it covers are on disk before the snapshot says so.
  auto bytes = mapping_->sync_trajectory();
  if (!bytes.ok()) return bytes.error();
  CheckpointMeta meta;
  meta.frames = mapping_->frames();
  meta.last_timestamp = mapping_->last_timestamp();
  meta.trajectory_bytes = *bytes;
  meta.width = config_.run.resolution.width;
  meta.height = config_.run.resolution.height;
  meta.capacity = mapping_->slam().pool().capacity();
  meta.seconds = (resumed_ ? resumed_->seconds : 0.0) + seconds;
  meta.labels = semantics_ != nullptr;
  update_counters();
  EF_RETURN_IF_ERROR(write_checkpoint(out_folder_, meta, mapping_->slam(), stats_, checkpoint_names_));
  stats_.record_ms(st_checkpoint_, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  stats_extra_[kExtraCheckpoints].value += 1;
  if (with_preview) {
    // A picture that cannot be written (a permission, a file system's error) does not stop the
    // mapping: the checkpoint is on disk; the failure is counted and the first one kept, which the
    // run warns of (checkpoint_preview_error()). The previous preview.png stays whole.
    if (Status s = write_checkpoint_preview(); !s.ok()) {
      stats_.increment(c_.checkpoint_previews_failed);
      if (!checkpoint_preview_error_) checkpoint_preview_error_ = s.error();
    }
  }
  if (log_ != nullptr && config_.log.map) {
    // The map into the field log too (Foxglove's 3D panel); a failure is the log's, reported at the end.
    const auto t1 = std::chrono::steady_clock::now();
    SurfelCloudView cloud = slam::surfel_cloud_view(mapping_->slam().pool());
    if (semantics_ != nullptr) semantics_->add_label_columns(mapping_->slam().pool(), cloud);
    (void)log_->log_map(meta.last_timestamp, cloud);
    stats_.record_ms(st_log_map_, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count());
  }
  return Status::success();
}

Status RunPipeline::write_checkpoint_preview() {
  if (!config_.run.preview || previewer_ == nullptr || mapping_->slam().pool().size() == 0) return Status::success();
  const auto t0 = std::chrono::steady_clock::now();
  SurfelCloudView cloud = slam::surfel_cloud_view(mapping_->slam().pool());
  if (semantics_ != nullptr) semantics_->add_label_columns(mapping_->slam().pool(), cloud);
  PreviewOptions po;
  po.title = preview_title(mapping_->frames());
  const std::string file = (std::filesystem::path(out_folder_) / "preview.png").string();
  EF_RETURN_IF_ERROR(previewer_->write(file, cloud, preview_path_.poses(), po));
  stats_.record_ms(st_checkpoint_preview_,
                   std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  return Status::success();
}

std::string RunPipeline::preview_title(int64_t frames) const {
  return config_.run.source + ", " + std::to_string(frames) + " frames";
}

bool RunPipeline::Every::due(std::chrono::steady_clock::time_point now) {
  if (seconds <= 0 || now < next) return false;
  next = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
  return true;
}

void RunPipeline::Every::start(double interval_s, std::chrono::steady_clock::time_point now) {
  seconds = interval_s;
  next = now;
  (void)due(now);  // the first time one interval from now
}

Status RunPipeline::maybe_checkpoint() {
  const auto now = std::chrono::steady_clock::now();
  if (!checkpoint_every_.due(now)) return Status::success();
  return checkpoint(std::chrono::duration<double>(now - start_).count());
}

void RunPipeline::sample_rate(std::chrono::steady_clock::time_point now) {
  const double t = std::chrono::duration<double>(now - start_).count();
  if (!rate_.empty() && t - rate_.back().seconds < rate_interval_) return;
  if (rate_.size() == kRateSamples) {
    std::size_t k = 0;
    for (std::size_t j = 0; j < rate_.size(); j += 2) rate_[k++] = rate_[j];
    rate_.resize(k);
    rate_interval_ *= 2;
  }
  rate_.push_back(RateSample{t, mapping_->frames()});
}

Status RunPipeline::maybe_write_stats() {
  const auto now = std::chrono::steady_clock::now();
  if (!stats_every_.due(now)) return Status::success();
  update_counters();
  return write_stats("running", mapping_->frames(), std::chrono::duration<double>(now - start_).count());
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
  if (previewer_ != nullptr) preview_path_.add(mapping_->last_result().T_world_cam);
  if (slot.working.has_pose && config_.run.report && reference_seen_++ % reference_stride_ == 0) {
    if (reference_.size() == kReferencePoses) {  // full: keep every other, take every 2k-th from now on
      std::size_t k = 0;
      for (std::size_t j = 0; j < reference_.size(); j += 2) reference_[k++] = reference_[j];
      reference_.resize(k);
      reference_stride_ *= 2;
    }
    reference_.push_back(TimedPose{slot.working.timestamp, slot.working.T_wc, false});
  }
  observer.frame_mapped(*this);
  return true;
}

void RunPipeline::check_stop(RunObserver& observer, RunOutcome& outcome) {
  if (stop_sent_ || !observer.stop_requested(*this)) return;
  outcome.stopped = true;
  stop_sent_ = true;
  front_->request_stop();  // drains: every frame captured or prepared is still mapped
}

void RunPipeline::front_loop() {
  StageRing<PreparedFrame>& ring = *ring_;
  while (true) {
    PreparedFrame* slot = ring.acquire(kFront, kPoll);
    if (slot == nullptr) {
      if (ring.closed()) return;  // mapping gave up
      continue;
    }
    // kNothingYet: the same slot again (a live camera had nothing within the poll time).
    if (front_->step(*slot) == FrontStage::Step::kNothingYet) continue;
    const bool end = slot->end;
    ring.release(kFront);
    if (end) return;
  }
}

RunOutcome RunPipeline::run(RunObserver& observer) {
  RunOutcome outcome;
  const auto start = std::chrono::steady_clock::now();
  start_ = start;
  stats_every_.start(config_.output.stats_seconds, start);
  checkpoint_every_.start(config_.output.checkpoint_seconds, start);
  pin_current_thread_or_warn(config_.pipeline.mapping_cpu, "mapping");
  front_->start_capture();
  StageRing<PreparedFrame>& ring = *ring_;
  std::thread front_thread;
  if (config_.pipeline.threads >= 2) {
    front_thread = std::thread([this] {
      pin_current_thread_or_warn(config_.pipeline.front_cpu, "front stage");
      front_loop();
    });
  }
  // The CNN's thread: on the front's core with two threads, on its own with three.
  if (cnn_ != nullptr) cnn_->start(config_.pipeline.threads == 3 ? config_.pipeline.cnn_cpu : config_.pipeline.front_cpu);
  while (true) {
    check_stop(observer, outcome);
    if (config_.pipeline.threads == 1) {
      // Every step in turn on this thread, on the ring's one slot (the CNN runs inside the front step).
      PreparedFrame* slot = ring.acquire(kFront, kPoll);
      if (slot == nullptr || front_->step(*slot) == FrontStage::Step::kNothingYet) continue;
      ring.release(kFront);
    }
    PreparedFrame* slot = ring.acquire(kMapping, kPoll);
    if (slot == nullptr) continue;  // the front step always ends with an end slot
    const bool more = consume(*slot, observer, outcome);
    ring.release(kMapping);
    if (!more) break;
    // A stats.json or checkpoint that cannot be written (a full disk) ends the run like any
    // output's failure.
    Status s = maybe_checkpoint();
    if (s.ok()) s = maybe_write_stats();
    if (config_.run.report) sample_rate(std::chrono::steady_clock::now());
    if (!s.ok()) {
      outcome.error = s.error();
      break;
    }
  }
  // Ended (the end slot, or an error): the camera stops, and threads still waiting or working on
  // later slots give up. The CNN's results for mapped frames are still fused.
  front_->request_stop();
  ring.close();
  if (front_thread.joinable()) front_thread.join();
  if (cnn_ != nullptr) {
    if (!outcome.error) {
      if (Status s = mapping_->drain_cnn(); !s.ok()) outcome.error = s.error();
    }
    cnn_->close();
  }
  outcome.frames = mapping_->frames();
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  update_counters();
  return outcome;
}

OutputFiles RunPipeline::write_outputs(const RunOutcome& outcome) {
  OutputFiles out;
  const std::filesystem::path dir(out_folder_);
  out.trajectory = (dir / "trajectory.txt").string();
  out.map = (dir / "map.ply").string();
  out.stats = (dir / "stats.json").string();
  slam::SurfelSlam& slam = mapping_->slam();

  if (auto closed = mapping_->close_trajectory(); !closed.ok()) {
    out.errors.push_back(closed.error());
  } else {
    out.wrote_trajectory = true;
    out.trajectory_corrected = closed->corrected;
    out.trajectory_kept = closed->kept;
  }
  if (semantics_ != nullptr) {
    if (Status s = semantics_->finish(slam); !s.ok()) out.errors.push_back(s.error());
  }
  // The final checkpoint: a finished run can be continued or exported like an interrupted one.
  if (config_.output.checkpoint_seconds > 0 && !outcome.error) {
    // (its preview is the final one below, drawn along the trajectory as closed)
    if (Status s = checkpoint(outcome.seconds, /*with_preview=*/false); !s.ok()) out.errors.push_back(s.error());
  }
  // Nothing mapped (this session or a resumed one): no map and no trajectory to give, and a run that
  // did nothing did not work (a recording opened with the wrong size=, an empty source).
  const bool mapped = slam.frames() > 0;
  if (!mapped) {
    std::error_code ec;
    if (out.wrote_trajectory) std::filesystem::remove(out.trajectory, ec);  // its header alone
    out.wrote_trajectory = false;
    if (!outcome.error)
      out.errors.push_back(error(ErrorCode::kNotFound, config_.run.source + ": no frame was mapped (the source gave "
                                                                          "none): no map or trajectory written"));
  }
  if (config_.run.map && mapped) {
    const std::string comment =
        "edgefusion map of " + config_.run.source + ", " + std::to_string(outcome.frames) + " frames";
    SurfelCloudView cloud = slam::surfel_cloud_view(slam.pool());
    if (semantics_ != nullptr) semantics_->add_label_columns(slam.pool(), cloud);
    if (Status s = write_surfel_ply(out.map, cloud, comment); !s.ok()) out.errors.push_back(s.error());
    else out.wrote_map = true;
  }
  if ((config_.run.preview || config_.run.report) && mapped) {
    // The picture of the final map, and the page about the run, with the camera's path
    // (trajectory.txt, as just written).
    SurfelCloudView cloud = slam::surfel_cloud_view(slam.pool());
    if (semantics_ != nullptr) semantics_->add_label_columns(slam.pool(), cloud);
    auto path = out.wrote_trajectory ? read_preview_path(out.trajectory) : Result<std::vector<SE3>>(std::vector<SE3>{});
    if (!path.ok()) out.errors.push_back(path.error());
    if (config_.run.preview && path.ok()) {
      PreviewOptions po;
      po.title = preview_title(outcome.frames);
      const std::string preview = (dir / "preview.png").string();
      if (Status s = previewer_->write(preview, cloud, *path, po); !s.ok()) {
        out.errors.push_back(s.error());
      } else {
        out.preview = preview;
        out.wrote_preview = true;
      }
    }
    if (config_.run.report && path.ok()) {
      update_counters();
      ReportInputs in;
      in.title = config_.run.source;
      in.state = outcome.error ? "failed: " + outcome.error->message
                 : !out.errors.empty() ? "failed: " + out.errors.front().message
                 : outcome.camera_lost ? "camera lost"
                 : outcome.stopped     ? "stopped"
                                       : "finished";
      in.frames = outcome.frames;
      in.seconds = outcome.seconds;
      in.facts = {{"output folder", out_folder_},
                  {"working resolution", std::to_string(config_.run.resolution.width) + "x" +
                                             std::to_string(config_.run.resolution.height)},
                  {"surfels", std::to_string(slam.pool().size()) + " of " + std::to_string(slam.pool().capacity())},
                  {"lost frames / relocalised", std::to_string(slam.lost_frames()) + " / " +
                                                    std::to_string(slam.relocalisations())},
                  {"threads", std::to_string(config_.pipeline.threads)}};
      if (semantics_ != nullptr) in.facts.emplace_back("labels", semantics_->describe());
      in.stats = &stats_;
      if (out.wrote_preview) in.preview_png = out.preview;
      if (semantics_ != nullptr) {  // the map's classes (the preview counts the same; it may be off)
        in.class_counts.assign(kNumClassesWithUnknown, 0);
        for (std::size_t i = 0; i < cloud.count; ++i)
          if (cloud.class_id[i] < kNumClassesWithUnknown) ++in.class_counts[cloud.class_id[i]];
      }
      in.rate = rate_;
      in.rate.push_back(RateSample{outcome.seconds, outcome.frames});
      in.config_text = config_.describe();
      // Against the source's reference poses, where it has them: the ATE (eval/trajectory_eval.h,
      // as `edgefusion eval ate`) over the reference poses kept, and the aligned reference path.
      std::vector<Eigen::Vector3d> reference_path;
      if (reference_.size() >= 3 && out.wrote_trajectory) {
        Trajectory gt;
        gt.source = config_.run.source + " (reference poses)";
        gt.poses = reference_;
        auto est = read_tum_trajectory(out.trajectory);
        auto ate = est.ok() ? evaluate_ate(gt, *est) : Result<AteResult>(est.error());
        if (ate.ok()) {
          char text[160];
          std::snprintf(text, sizeof text, "%.2f cm RMSE, %.2f cm median, %.2f cm max over %d poses%s",
                        ate->rmse_m * 100, ate->median_m * 100, ate->max_m * 100, ate->pairs,
                        reference_stride_ > 1 ? (" (every " + std::to_string(reference_stride_) + "th frame)").c_str() : "");
          in.facts.emplace_back("ATE against the source's reference poses", text);
          const SE3 T_est_gt = ate->T_gt_est.inverse();
          for (const TimedPose& r : reference_) reference_path.push_back(T_est_gt * r.T_wc.translation());
        } else {
          in.facts.emplace_back("ATE against the source's reference poses", "not computed: " + ate.error().message);
        }
      }
      const std::string report = (dir / "report.html").string();
      if (Status s = write_run_report(report, in, top_view(cloud, *path, reference_path)); !s.ok()) {
        out.errors.push_back(s.error());
      } else {
        out.report = report;
        out.wrote_report = true;
      }
    }
  }
  if (log_ != nullptr) {
    out.log = log_path_;
    out.log_frames = log_->frames();
    const char* how = outcome.error ? "failed" : (outcome.stopped || outcome.camera_lost) ? "stopped" : "finished";
    (void)log_->log_text(mapping_->last_timestamp(), outcome.error ? foxglove::LogLevel::kError : foxglove::LogLevel::kInfo,
                         std::string("edgefusion run: ") + how + " after " + std::to_string(outcome.frames) + " frames" +
                             (outcome.error ? ": " + outcome.error->message : std::string()),
                         *log_encoder_);
    if (Status s = log_->close(); !s.ok()) out.errors.push_back(s.error());
    else out.wrote_log = true;
  }
  // Last, so that it tells how the run and its outputs ended.
  std::string state = "finished";
  if (outcome.error) state = "failed: " + outcome.error->message;
  else if (!out.errors.empty()) state = "failed: " + out.errors.front().message;
  else if (outcome.camera_lost) state = "camera lost";  // output.resume_interrupted continues such a run
  else if (outcome.stopped) state = "stopped";
  if (Status s = write_stats(state.c_str(), outcome.frames, outcome.seconds); !s.ok()) out.errors.push_back(s.error());
  else out.wrote_stats = true;
  return out;
}

Result<FinalLabelCounts> RunPipeline::render_final_labels(FrameSource& replay, const std::function<bool()>& stop) {
  if (semantics_ == nullptr)
    return error(ErrorCode::kInvalidArgument, "--labels-final-out needs labels: drop --no-labels");
  const std::string trajectory = (std::filesystem::path(out_folder_) / "trajectory.txt").string();
  return pipeline::render_final_labels(config_.run, config_.labels, replay, trajectory, mapping_->slam(), *semantics_,
                                       stop);
}

}  // namespace ef::pipeline
