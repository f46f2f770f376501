#include "daemon/mqtt_sink.hpp"

#include <mosquitto.h>

#include <utility>

#include <nlohmann/json.hpp>

#include "core/log.hpp"
#include "daemon/journal.hpp"

namespace vgr::daemon {

namespace {

std::once_flag libInit;

std::string offlinePayload() { return R"({"state":"offline"})"; }

}  // namespace

MqttSink::MqttSink(config::MqttConfig config, std::string cell, std::string version)
    : cfg_(std::move(config)), base_(cfg_.prefix + "/" + cell), version_(std::move(version)) {}

MqttSink::~MqttSink() {
  stop();
  if (mosq_ != nullptr) mosquitto_destroy(mosq_);
}

Result<void> MqttSink::setUp(mosquitto* mosq) const {
  const std::string broker = "MQTT broker " + cfg_.host + ":" + std::to_string(cfg_.port);
  auto check = [&](int rc, const std::string& what) -> Result<void> {
    if (rc == MOSQ_ERR_SUCCESS) return {};
    return fail(Status::BadArgument, broker + ": " + what + ": " + mosquitto_strerror(rc));
  };
  const std::string will = offlinePayload();
  if (auto r = check(mosquitto_will_set(mosq, statusTopic().c_str(), static_cast<int>(will.size()), will.data(), 1, true),
                     "will");
      !r)
    return r;
  if (!cfg_.username.empty()) {
    if (auto r = check(mosquitto_username_pw_set(mosq, cfg_.username.c_str(),
                                                 cfg_.password.empty() ? nullptr : cfg_.password.c_str()),
                       "username/password");
        !r)
      return r;
  }
  if (!cfg_.tlsCaFile.empty()) {
    // libmosquitto opens each file here and says only "invalid arguments": name them all.
    std::string files = "TLS files (ca_file " + cfg_.tlsCaFile;
    if (!cfg_.tlsCertFile.empty()) files += ", cert_file " + cfg_.tlsCertFile + ", key_file " + cfg_.tlsKeyFile;
    files += ")";
    if (auto r = check(mosquitto_tls_set(mosq, cfg_.tlsCaFile.c_str(), nullptr,
                                         cfg_.tlsCertFile.empty() ? nullptr : cfg_.tlsCertFile.c_str(),
                                         cfg_.tlsKeyFile.empty() ? nullptr : cfg_.tlsKeyFile.c_str(), nullptr),
                       files + " missing or unreadable");
        !r)
      return r;
    mosquitto_tls_insecure_set(mosq, cfg_.tlsInsecure);
  }
  return {};
}

Result<void> MqttSink::checkSetup() const {
  std::call_once(libInit, [] { mosquitto_lib_init(); });
  mosquitto* mosq = mosquitto_new(nullptr, true, nullptr);
  if (mosq == nullptr) return fail(Status::Internal, "MQTT: mosquitto_new failed");
  auto r = setUp(mosq);
  mosquitto_destroy(mosq);
  return r;
}

Result<void> MqttSink::start() {
  std::call_once(libInit, [] { mosquitto_lib_init(); });
  const std::string broker = "MQTT broker " + cfg_.host + ":" + std::to_string(cfg_.port);
  const std::string id = cfg_.clientId.empty() ? "vgrd-" + base_.substr(base_.rfind('/') + 1) : cfg_.clientId;
  mosq_ = mosquitto_new(id.c_str(), true, this);
  if (mosq_ == nullptr) return fail(Status::Internal, broker + ": mosquitto_new failed");
  mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  mosquitto_connect_callback_set(mosq_, &MqttSink::onConnect);
  mosquitto_disconnect_callback_set(mosq_, &MqttSink::onDisconnect);
  mosquitto_publish_callback_set(mosq_, &MqttSink::onPublish);
  if (auto r = setUp(mosq_); !r) return r;
  auto check = [&](int rc, const char* what) -> Result<void> {
    if (rc == MOSQ_ERR_SUCCESS) return {};
    return fail(Status::BadArgument, broker + ": " + what + ": " + mosquitto_strerror(rc));
  };
  mosquitto_reconnect_delay_set(mosq_, static_cast<unsigned>(cfg_.reconnectMinS), static_cast<unsigned>(cfg_.reconnectMaxS),
                                true);
  // Unreachable now is not fatal: the network thread keeps reconnecting with back-off.
  const int rc = mosquitto_connect_async(mosq_, cfg_.host.c_str(), cfg_.port, cfg_.keepaliveS);
  if (rc != MOSQ_ERR_SUCCESS)
    log::warn("mqtt", "{}: {} (retrying every {}..{} s)", broker, rc == MOSQ_ERR_ERRNO ? "unreachable" : mosquitto_strerror(rc),
              cfg_.reconnectMinS, cfg_.reconnectMaxS);
  if (auto r = check(mosquitto_loop_start(mosq_), "network thread"); !r) return r;
  started_ = true;
  log::info("mqtt", "{}: publishing {} and {}", broker, resultTopic(), statusTopic());
  return {};
}

void MqttSink::stop() {
  if (!started_) return;
  started_ = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (counters_.connected) {
      // A clean disconnect does not fire the will: say "offline" ourselves, before DISCONNECT.
      const std::string off = offlinePayload();
      int mid = 0;
      if (mosquitto_publish(mosq_, &mid, statusTopic().c_str(), static_cast<int>(off.size()), off.data(), 1, true) ==
          MOSQ_ERR_SUCCESS)
        statusMids_.insert(mid);
    }
  }
  mosquitto_disconnect(mosq_);
  mosquitto_loop_stop(mosq_, false);
  const MqttCounters c = counters();
  log::info("mqtt", "stopped: {} results published, {} dropped, {} left queued, {} connects", c.published, c.dropped,
            c.queued, c.connects);
}

void MqttSink::publishResult(const CycleResult& r) {
  std::string payload = Journal::toJson(r, robots_);
  std::lock_guard<std::mutex> lock(mutex_);
  if (queue_.size() >= static_cast<std::size_t>(cfg_.queueCapacity)) {
    queue_.pop_front();
    ++counters_.dropped;
  }
  queue_.push_back(std::move(payload));
  drainLocked();
}

void MqttSink::setStatus(const MqttStatus& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (haveStatus_ && status == status_) return;
  status_ = status;
  haveStatus_ = true;
  if (counters_.connected) publishStatusLocked();
}

MqttCounters MqttSink::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MqttCounters c = counters_;
  c.queued = queue_.size();
  return c;
}

void MqttSink::drainLocked() {
  // Results go to libmosquitto only while connected and under the in-flight limit, so the
  // bounded queue (not libmosquitto's unbounded one) holds what the broker has not taken.
  const std::string topic = resultTopic();
  while (counters_.connected && inflight_ < kMaxInflight && !queue_.empty()) {
    const std::string& p = queue_.front();
    const int rc = mosquitto_publish(mosq_, nullptr, topic.c_str(), static_cast<int>(p.size()), p.data(), 1, false);
    if (rc != MOSQ_ERR_SUCCESS) break;  // NO_CONN: it stays queued until the next connect
    ++inflight_;
    queue_.pop_front();
  }
}

void MqttSink::publishStatusLocked() {
  nlohmann::json j;
  j["state"] = "online";
  j["ready"] = status_.ready;
  j["camera"] = status_.camera;
  j["job"] = status_.job;
  j["version"] = version_;
  const std::string text = j.dump();
  int mid = 0;
  if (mosquitto_publish(mosq_, &mid, statusTopic().c_str(), static_cast<int>(text.size()), text.data(), 1, true) ==
      MOSQ_ERR_SUCCESS)
    statusMids_.insert(mid);
}

// Network thread.
void MqttSink::onConnect(mosquitto*, void* self, int rc) {
  auto* s = static_cast<MqttSink*>(self);
  if (rc != 0) {
    log::warn("mqtt", "broker {}:{} refused the connection: {}", s->cfg_.host, s->cfg_.port, mosquitto_connack_string(rc));
    return;
  }
  std::lock_guard<std::mutex> lock(s->mutex_);
  s->counters_.connected = true;
  ++s->counters_.connects;
  log::info("mqtt", "connected to {}:{} ({} results queued)", s->cfg_.host, s->cfg_.port, s->queue_.size());
  s->publishStatusLocked();  // retained: replaces the will's "offline"
  s->drainLocked();
}

void MqttSink::onDisconnect(mosquitto*, void* self, int rc) {
  auto* s = static_cast<MqttSink*>(self);
  std::lock_guard<std::mutex> lock(s->mutex_);
  if (s->counters_.connected && rc != 0) log::warn("mqtt", "lost the broker {}:{}: reconnecting", s->cfg_.host, s->cfg_.port);
  s->counters_.connected = false;
}

void MqttSink::onPublish(mosquitto*, void* self, int mid) {
  auto* s = static_cast<MqttSink*>(self);
  std::lock_guard<std::mutex> lock(s->mutex_);
  if (s->statusMids_.erase(mid) > 0) return;
  if (s->inflight_ > 0) --s->inflight_;
  ++s->counters_.published;
  s->drainLocked();
}

}  // namespace vgr::daemon
