// vgrd's MQTT sink (libmosquitto; topics and payloads in docs/plant.md):
//   <prefix>/<cell>/result  every cycle's result, the journal's JSON line (docs/journal.md), QoS 1
//   <prefix>/<cell>/status  retained {"state":"online","ready":..,"camera":..,"job":..,"version":..};
//                           the Last Will (retained) and a clean stop set {"state":"offline"}
// The network is libmosquitto's own thread (mosquitto_loop_start): it connects, reconnects
// with exponential back-off (mqtt.reconnect_min_s .. reconnect_max_s) and runs the
// callbacks. Results wait in a bounded queue (mqtt.queue) while the broker is away or
// kMaxInflight messages are unacknowledged; when it is full the oldest result is dropped
// and counted (STYLE.md rule 8). A broker that is down at start is not an error.
//
// Threads: start()/stop() on the owning thread; publishResult() from the cycle thread and
// setStatus() from any thread: both take one short lock and never wait for the network.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"
#include "daemon/journal.hpp"  // JournalRobot: the result message is the journal line

struct mosquitto;
struct mosquitto_message;

namespace vgr::daemon {

struct MqttStatus {
  bool ready = false;   // READY as the PLC sees it
  bool camera = false;  // the camera streams
  int job = 0;          // job of the latest cycle (the cell's first job before any)
  bool operator==(const MqttStatus&) const = default;
};

struct MqttCounters {
  std::uint64_t published = 0;  // results the broker acknowledged (PUBACK)
  std::uint64_t dropped = 0;    // results dropped from the full queue
  std::uint64_t connects = 0;   // successful connections (the first one included)
  std::size_t queued = 0;       // results waiting (not yet handed to libmosquitto)
  bool connected = false;
};

class MqttSink {
 public:
  static constexpr int kMaxInflight = 20;  // results handed to libmosquitto and not yet acknowledged

  MqttSink(config::MqttConfig config, std::string cell, std::string version);
  ~MqttSink();  // stop()
  MqttSink(const MqttSink&) = delete;
  MqttSink& operator=(const MqttSink&) = delete;

  // Sets the will, TLS and credentials, starts connecting and the network thread. Errors
  // (bad TLS files, no memory) name the broker.
  Result<void> start();
  // What start() sets up (will, credentials, TLS files: libmosquitto opens the files),
  // on a handle that never connects; for `vgrd --check`. Errors as start()'s.
  Result<void> checkSetup() const;
  // Publishes the retained "offline" status, disconnects and joins the network thread.
  void stop();

  void publishResult(const CycleResult& r);
  // Before start(): the robots whose deliveries the result message lists, as the journal
  // line does (daemon/journal.hpp journalRobots()).
  void setRobots(std::vector<JournalRobot> robots) { robots_ = std::move(robots); }
  void setStatus(const MqttStatus& status);
  MqttCounters counters() const;

  std::string resultTopic() const { return base_ + "/result"; }
  std::string statusTopic() const { return base_ + "/status"; }

 private:
  static void onConnect(mosquitto*, void* self, int rc);
  static void onDisconnect(mosquitto*, void* self, int rc);
  static void onPublish(mosquitto*, void* self, int mid);
  Result<void> setUp(mosquitto* mosq) const;  // will, credentials, TLS (start() and checkSetup())
  void drainLocked();
  void publishStatusLocked();

  const config::MqttConfig cfg_;
  std::vector<JournalRobot> robots_;
  const std::string base_;     // <prefix>/<cell>
  const std::string version_;
  mosquitto* mosq_ = nullptr;
  bool started_ = false;

  mutable std::mutex mutex_;
  std::deque<std::string> queue_;
  int inflight_ = 0;
  std::set<int> statusMids_;  // status publications in flight: their PUBACKs are not results'
  MqttStatus status_;
  bool haveStatus_ = false;
  MqttCounters counters_;
};

}  // namespace vgr::daemon
