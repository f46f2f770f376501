// A token bucket: at most `ratePerSecond` events on average, `burst` at once. The servers
// use it so that what one peer sends costs the daemon a bounded share of a core whatever it
// does (a connection storm, thousands of pipelined requests): what is over the budget waits
// in the peer's socket, where TCP flow control holds it back (docs/robustness.md).
// Not thread-safe: one per owner (a connection, an acceptor) on its thread.
#pragma once

#include <algorithm>
#include <chrono>

namespace vgr {

class TokenBucket {
 public:
  using Clock = std::chrono::steady_clock;

  TokenBucket(double ratePerSecond, double burst) : rate_(ratePerSecond), burst_(burst), tokens_(burst) {}

  // Takes one token when there is one.
  bool take(Clock::time_point now = Clock::now()) {
    refill(now);
    if (tokens_ < 1.0) return false;
    tokens_ -= 1.0;
    return true;
  }

  // When the next token is there (now when there is one).
  Clock::time_point nextToken(Clock::time_point now = Clock::now()) {
    refill(now);
    if (tokens_ >= 1.0) return now;
    return now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>((1.0 - tokens_) / rate_));
  }

 private:
  void refill(Clock::time_point now) {
    if (last_ != Clock::time_point{}) tokens_ = std::min(burst_, tokens_ + std::chrono::duration<double>(now - last_).count() * rate_);
    last_ = now;
  }

  double rate_, burst_, tokens_;
  Clock::time_point last_{};
};

}  // namespace vgr
