#include "platform/devices/status_panel.h"

namespace ef {

const char* led_pattern_name(LedPattern pattern) {
  switch (pattern) {
    case LedPattern::kOff: return "off";
    case LedPattern::kTracking: return "tracking";
    case LedPattern::kLost: return "lost";
    case LedPattern::kLogging: return "logging";
  }
  return "?";
}

void StatusLed::set_pattern(LedPattern pattern, int64_t now_ms) {
  if (pattern == pattern_) return;  // keep the blink phase
  pattern_ = pattern;
  pattern_start_ms_ = now_ms;
}

bool StatusLed::lit_at(int64_t now_ms) const {
  const auto blink = [&](int64_t half_period_ms) {
    if (half_period_ms <= 0) return true;
    const int64_t elapsed = now_ms > pattern_start_ms_ ? now_ms - pattern_start_ms_ : 0;
    return (elapsed / half_period_ms) % 2 == 0;  // "on" half first
  };
  switch (pattern_) {
    case LedPattern::kOff: return false;
    case LedPattern::kTracking: return true;
    case LedPattern::kLost: return blink(timing_.fast_half_period_ms);
    case LedPattern::kLogging: return blink(timing_.slow_half_period_ms);
  }
  return false;
}

Status StatusLed::tick(int64_t now_ms) {
  const bool level = lit_at(now_ms);
  if (driven_ && level == driven_level_) return Status();
  if (line_ != nullptr) EF_RETURN_IF_ERROR(line_->set(level));
  driven_ = true;
  driven_level_ = level;
  return Status();
}

int Debouncer::update(bool raw, int64_t now_ms) {
  if (!started_) {
    started_ = true;
    stable_ = candidate_ = raw;
    candidate_since_ms_ = now_ms;
    return 0;
  }
  if (raw != candidate_) {  // the level moved: restart the hold time (a bounce restarts it too)
    candidate_ = raw;
    candidate_since_ms_ = now_ms;
  }
  if (candidate_ != stable_ && now_ms - candidate_since_ms_ >= debounce_ms_) {
    stable_ = candidate_;
    return stable_ ? +1 : -1;
  }
  return 0;
}

Result<bool> StartStopButton::poll(int64_t now_ms) {
  if (line_ == nullptr) return false;
  EF_ASSIGN_OR_RETURN(const bool level, line_->get());
  if (debouncer_.update(level, now_ms) > 0) {
    running_ = !running_;
    return true;
  }
  return false;
}

}  // namespace ef
