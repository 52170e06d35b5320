#include "pipeline/cnn_worker.h"

#include <chrono>

#include "platform/cpu/thread_affinity.h"

namespace ef::pipeline {

Result<std::unique_ptr<CnnWorker>> CnnWorker::create(RunSemantics& semantics, int working_width, int working_height,
                                                     bool threaded, double test_delay_ms) {
  std::unique_ptr<CnnWorker> w(new CnnWorker(semantics));
  w->threaded_ = threaded;
  w->test_delay_ms_ = test_delay_ms;
  for (CnnJob& job : w->jobs_) {
    job.frame.allocate(working_width, working_height, /*with_labels=*/false);
    job.frame.name.reserve(Frame::kMaxFrameName);
    semantics.allocate(job.cnn);
  }
  return w;
}

CnnWorker::~CnnWorker() { close(); }

void CnnWorker::start(int cpu) {
  if (!threaded_ || thread_.joinable()) return;
  thread_ = std::thread([this, cpu] {
    pin_current_thread_or_warn(cpu, "CNN");
    loop();
  });
}

void CnnWorker::run_job(CnnJob& job) {
  if (test_delay_ms_ > 0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(test_delay_ms_));
  job.error.reset();
  if (Status s = semantics_.segment(job.frame, job.cnn); !s.ok()) job.error = s.error();
}

bool CnnWorker::offer(const Frame& working, int64_t number, bool fuse, bool wait) {
  std::unique_lock<std::mutex> lock(mutex_);
  int free = -1;
  while (true) {
    for (int i = 0; i < kJobs && free < 0; ++i)
      if (state_[i] == State::kFree) free = i;
    if (free >= 0 || !wait || closed_) break;
    changed_.wait(lock);
  }
  if (free < 0) return false;
  // The copy is made outside the lock: the job is the front thread's until it is queued.
  state_[free] = State::kTaken;
  lock.unlock();
  CnnJob& job = jobs_[free];
  job.number = number;
  job.fuse = fuse;
  job.frame.color.copy_from(working.color.view());
  job.frame.depth.copy_from(working.depth.view());
  job.frame.name.assign(working.name);  // within the reserved capacity (Frame::kMaxFrameName)
  job.frame.index = working.index;
  job.frame.timestamp = working.timestamp;
  job.cnn.valid = false;
  if (!threaded_) run_job(job);
  lock.lock();
  state_[free] = threaded_ ? State::kQueued : State::kDone;
  changed_.notify_all();
  return true;
}

void CnnWorker::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    int next = -1;
    for (int i = 0; i < kJobs; ++i)
      if (state_[i] == State::kQueued && (next < 0 || jobs_[i].number < jobs_[next].number)) next = i;
    if (closed_) return;
    if (next < 0) {
      changed_.wait(lock);
      continue;
    }
    state_[next] = State::kRunning;
    lock.unlock();
    run_job(jobs_[next]);
    lock.lock();
    state_[next] = State::kDone;
    changed_.notify_all();
  }
}

CnnJob* CnnWorker::take(int64_t up_to, int64_t wait_for) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (wait_for >= 0) {
    const auto in_flight = [&] {
      for (int i = 0; i < kJobs; ++i)
        if ((state_[i] == State::kQueued || state_[i] == State::kRunning) && jobs_[i].number == wait_for) return true;
      return false;
    };
    while (in_flight() && !closed_) changed_.wait(lock);
  }
  int best = -1;
  for (int i = 0; i < kJobs; ++i)
    if (state_[i] == State::kDone && jobs_[i].number <= up_to && (best < 0 || jobs_[i].number < jobs_[best].number))
      best = i;
  if (best < 0) return nullptr;
  state_[best] = State::kTaken;
  return &jobs_[best];
}

void CnnWorker::release(CnnJob* job) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < kJobs; ++i)
    if (&jobs_[i] == job) state_[i] = State::kFree;
  changed_.notify_all();
}

bool CnnWorker::pending(int64_t up_to) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < kJobs; ++i)
    if ((state_[i] == State::kQueued || state_[i] == State::kRunning) && jobs_[i].number <= up_to) return true;
  return false;
}

void CnnWorker::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    changed_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

std::size_t CnnWorker::bytes() const {
  std::size_t b = 0;
  for (const CnnJob& job : jobs_) b += job.frame.bytes() + job.cnn.bytes();
  return b;
}

}  // namespace ef::pipeline
