#include "protocol/robot_strict.hpp"

#include "protocol/robot_codec.hpp"  // parseStrictPoseFrame

#include <algorithm>
#include <utility>

#include <fmt/core.h>

namespace vgr::protocol {
namespace {

// Separators a robot program may put around its tokens (socket_send_line adds "\n",
// RAPID programs like '#'); skipped before a token and never part of one.
bool isSeparator(char c) { return c == '\r' || c == '\n' || c == '#' || c == ' ' || c == '\t' || c == '\0'; }

const std::string kNothing;

}  // namespace

std::string printable(std::string_view bytes) {
  std::string out;
  for (std::size_t i = 0; i < bytes.size() && i < kMaxStrictTokenChars; ++i) {
    const auto c = static_cast<unsigned char>(bytes[i]);
    if (c >= 0x20 && c < 0x7F)
      out.push_back(static_cast<char>(c));
    else
      out += fmt::format("\\x{:02x}", c);
  }
  if (bytes.size() > kMaxStrictTokenChars) out += "...";
  return out;
}

StrictExchange::StrictExchange(StrictTokens tokens) : tokens_(std::move(tokens)) {}

const std::string& StrictExchange::expected() const {
  switch (step_) {
    case Step::AwaitResult:
      break;
    case Step::AwaitReady:
      return tokens_.ready;
    case Step::AwaitDone:
      return tokens_.done;
    case Step::Idle:
      break;
  }
  return kNothing;
}

std::string StrictExchange::begin(std::string poseFrame) {
  poseFrame_ = std::move(poseFrame);
  rx_.clear();  // whatever came while idle was already reported and is not an answer
  step_ = Step::AwaitReady;
  return tokens_.command + tokens_.lineEnd;
}

std::string StrictExchange::noResult(Status status) {
  step_ = Step::Idle;
  poseFrame_.clear();
  return tokens_.none + "(" + std::to_string(statusCode(status)) + ")" + tokens_.lineEnd;
}

void StrictExchange::feed(std::string_view bytes) { rx_.append(bytes); }

StrictExchange::Event StrictExchange::failNow(Status status, std::string detail) {
  Event e;
  e.kind = EventKind::Failed;
  e.status = status;
  e.detail = std::move(detail);
  step_ = Step::Idle;
  rx_.clear();
  poseFrame_.clear();
  return e;
}

StrictExchange::Event StrictExchange::poll() {
  std::size_t skip = 0;
  while (skip < rx_.size() && isSeparator(rx_[skip])) ++skip;
  rx_.erase(0, skip);
  if (rx_.empty()) return {};

  if (step_ == Step::Idle && snapshotMode()) return pollSnapshot();
  if (step_ == Step::Idle || step_ == Step::AwaitResult) {
    Event e;
    e.kind = EventKind::Unexpected;
    e.detail = printable(rx_);
    rx_.clear();
    return e;
  }

  const std::string& want = expected();
  const std::size_t n = std::min(rx_.size(), want.size());
  if (rx_.compare(0, n, want, 0, n) != 0) {
    // Quote what came, up to its first separator.
    std::size_t end = 0;
    while (end < rx_.size() && !isSeparator(rx_[end])) ++end;
    const std::string got = printable(std::string_view(rx_).substr(0, end));
    const std::string what = fmt::format("expected '{}', got '{}'", want, got);
    return failNow(Status::UnknownCommand, what);
  }
  if (rx_.size() < want.size()) return {};  // a prefix of the token so far: wait
  // A longer word that merely starts with the token ("MoveJ_pose_done2") is wrong too,
  // once the byte after the token has arrived.
  if (rx_.size() > want.size() && !isSeparator(rx_[want.size()])) {
    std::size_t end = 0;
    while (end < rx_.size() && !isSeparator(rx_[end])) ++end;
    return failNow(Status::UnknownCommand,
                   fmt::format("expected '{}', got '{}'", want, printable(std::string_view(rx_).substr(0, end))));
  }
  rx_.erase(0, want.size());

  Event e;
  if (step_ == Step::AwaitReady) {
    step_ = Step::AwaitDone;
    e.kind = EventKind::SendPose;
    e.bytes = poseFrame_ + tokens_.lineEnd;
    return e;
  }
  step_ = Step::Idle;
  poseFrame_.clear();
  e.kind = EventKind::Completed;
  return e;
}

StrictExchange::Event StrictExchange::pollSnapshot() {
  // rx_ starts with a non-separator. "<snapshot>" then blanks, then "(...)" or "p[...]".
  const std::string& want = tokens_.snapshot;
  const std::size_t n = std::min(rx_.size(), want.size());
  Event e;
  if (rx_.compare(0, n, want, 0, n) != 0) {
    e.kind = EventKind::Unexpected;
    e.detail = printable(rx_);
    rx_.clear();
    return e;
  }
  if (rx_.size() < want.size()) return {};
  std::size_t at = want.size();
  while (at < rx_.size() && isSeparator(rx_[at])) ++at;
  if (at == rx_.size()) return {};
  const char open = rx_[at];
  if (open != '(' && open != 'p') {
    e.kind = EventKind::BadSnapshot;
    e.status = Status::BadArgument;
    e.detail = fmt::format("'{}' must be followed by the flange pose (x,y,z,rx,ry,rz), got '{}'", want,
                           printable(std::string_view(rx_).substr(at)));
    rx_.clear();
    return e;
  }
  const std::size_t close = rx_.find(open == '(' ? ')' : ']', at);
  if (close == std::string::npos) {
    if (rx_.size() - at <= kMaxStrictPoseFrameChars) return {};  // the rest of the frame is on its way
    e.kind = EventKind::BadSnapshot;
    e.status = Status::BadArgument;
    e.detail = fmt::format("no end of the pose frame within {} bytes after '{}'", kMaxStrictPoseFrameChars, want);
    rx_.clear();
    return e;
  }
  const std::string frame = rx_.substr(at, close + 1 - at);
  rx_.erase(0, close + 1);
  auto pose = parseStrictPoseFrame(frame);
  if (!pose) {
    e.kind = EventKind::BadSnapshot;
    e.status = pose.error().code;
    e.detail = fmt::format("snapshot pose '{}': {}", printable(frame), pose.error().message);
    return e;
  }
  step_ = Step::AwaitResult;
  e.kind = EventKind::Snapshot;
  e.pose = *pose;
  return e;
}

StrictExchange::Event StrictExchange::onTimeout() {
  if (step_ == Step::Idle || step_ == Step::AwaitResult) return {};
  const std::string partial = rx_.empty() ? std::string() : fmt::format(" (received '{}')", printable(rx_));
  return failNow(Status::ProcessingTimeout, fmt::format("no '{}' within the step timeout{}", expected(), partial));
}

StrictExchange::Event StrictExchange::onClosed() {
  if (step_ == Step::Idle || step_ == Step::AwaitResult) return {};
  return failNow(Status::Internal, fmt::format("connection lost while waiting for '{}'", expected()));
}

}  // namespace vgr::protocol
