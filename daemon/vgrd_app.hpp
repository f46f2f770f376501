// vgrd's wiring: one object that owns every part of the running daemon.
//
// Threads (ARCHITECTURE.md, "Threads"):
//   - the caller's thread runs the Asio io_context: robot sockets, result store, timers,
//     signals, systemd notifications;
//   - the Modbus server thread (libmodbus), one mutex around the register map;
//   - the camera acquisition thread (CameraWorker);
//   - the cycle thread (CycleRunner): localization and mapping; results reach the I/O
//     side by asio::post and the Modbus map through ModbusServer::publishResult.
#pragma once

#include <memory>

#include "config/cell_config.hpp"
#include "core/result.hpp"

namespace vgr::daemon {

class VgrdApp {
 public:
  explicit VgrdApp(config::CellConfig config);
  ~VgrdApp();

  // Opens the journal, starts the camera thread, the cycle thread and every server.
  // Errors name the part that failed (a port in use, a journal path not writable).
  Result<void> start();
  // Runs until SIGTERM/SIGINT; sends READY=1 to systemd once the camera streams and the
  // servers listen, WATCHDOG=1 when the unit asks for it, STOPPING=1 on the way out.
  int run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::daemon
