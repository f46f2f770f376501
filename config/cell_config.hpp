// The cell config (/etc/vgr/cell.yaml): typed, validated structs. parse -> validate -> apply
// (STYLE.md rule 4). Every field documents its unit and range; loadCellConfig() reports the
// first problem as "FILE:LINE: key 'a.b.c': what is wrong".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::config {

enum class WordOrder { HighWordFirst, LowWordFirst };
enum class Dialect { Ur, Abb };

struct CameraConfig {
  std::string name = "cam0";
  std::string driver = "aravis";   // registry name: "aravis"
  std::string address;             // IP address (loopback for the emulator); preferred on loopback
  std::string serial;              // optional; informative when address is set
  int timeoutMs = 1000;            // ms, [50, 60000]: trigger -> frame before the frame counts as lost
  double exposureUs = 5000;        // µs, [20, 1e6]
  int packetSize = 0;              // bytes, 0 (negotiate) or [576, 65000]: GigE Vision stream packet size
  int reconnectMinMs = 200;        // ms, [10, 60000]: first back-off after the camera drops out
  int reconnectMaxMs = 2000;       // ms, [reconnectMinMs, 600000]
};

// Pinhole camera above the conveyor plane: the skeleton's "known model" mapping. Real
// calibration files replace it (issue: calibration).
struct PlaneModelConfig {
  double fx = 1000, fy = 1000;     // px, > 0
  double cx = 639.5, cy = 511.5;   // px
  // Camera pose in the robot base frame: optical centre at (x, y, z) mm, looking straight
  // down (camera z = -base z), image x axis rotated by rzDeg about base z.
  double camX = 0, camY = 0, camZ = 500;  // mm
  double camRzDeg = 0;                    // deg
  double planeZ = 0;                      // mm: conveyor plane height in the base frame
};

struct ModbusConfig {
  bool enabled = true;
  std::string bind = "127.0.0.1";
  std::uint16_t port = 1502;
  WordOrder floatWordOrder = WordOrder::HighWordFirst;
};

struct RobotConfig {
  std::string name;
  Dialect dialect = Dialect::Ur;
  std::string bind = "127.0.0.1";
  std::uint16_t port = 0;
  int replyDeadlineMs = 1500;  // ms, [50, 60000]: a reply is always sent within this
};

struct ReferencePose {
  double x = 0, y = 0, z = 0;  // mm, base frame
  double rzDeg = 0;            // deg
};

struct JobConfig {
  int id = 1;                  // [1, 32767]: what the PLC writes to JOB_ID and robots send in GET,<job>
  std::string name;
  std::string method = "moments";
  int threshold = 0;           // gray level [0, 255]; 0 = automatic (Otsu)
  double minAreaPx = 2000;     // px², > 0
  double maxAreaPx = 1e7;      // px², > minAreaPx
  double partHeightMm = 0;     // mm, [0, 1000]: grasp height above the conveyor plane
  double angleOffsetDeg = 0;   // deg: template orientation relative to the locator's axis
  ReferencePose reference;     // taught reference the offsets are given from
};

struct SimConfig {
  std::uint64_t seed = 1;
  int width = 1280, height = 1024;  // px
  double noiseSigma = 2.0;          // gray levels
  std::string serial = "VGR-SIM-0";
};

struct CellConfig {
  std::string sourcePath;           // file it was loaded from
  std::string name = "cell";
  std::string journalPath = "/var/lib/vgr/journal.jsonl";
  std::string logLevel = "info";
  int cycleDeadlineMs = 1500;       // ms, [100, 60000]: trigger -> result, always answered
  CameraConfig camera;
  PlaneModelConfig model;
  ModbusConfig modbus;
  std::vector<RobotConfig> robots;
  std::vector<JobConfig> jobs;
  SimConfig sim;

  const JobConfig* findJob(int id) const;
};

// Loads and validates. Errors carry Status::BadArgument and a one-line message
// "FILE:LINE: key 'camera.timeout_ms': expected an integer in [50, 60000], got 'abc'".
Result<CellConfig> loadCellConfig(const std::string& path);
Result<CellConfig> parseCellConfig(const std::string& yamlText, const std::string& sourceName);

// The example simulated cell, embedded at build time from config/examples/sim-cell.yaml.
const std::string& embeddedSimCellYaml();

}  // namespace vgr::config
