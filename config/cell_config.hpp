// The cell config (/etc/vgr/cell.yaml): typed, validated structs. parse -> validate -> apply
// (STYLE.md rule 4). Every field documents its unit and range; loadCellConfig() reports the
// first problem as "FILE:LINE: key 'a.b.c': what is wrong".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/pose_limits.hpp"
#include "core/result.hpp"
#include "protocol/wire_types.hpp"

namespace vgr::config {

// The protocol layer owns the wire choices (protocol/wire_types.hpp); the config names them.
using protocol::AbbRotation;
using protocol::Delivery;
using protocol::Dialect;
using protocol::WordOrder;
using protocol::deliveryName;  // the cell.yaml spelling: "pose", "offset"
using protocol::dialectName;   // the cell.yaml spelling: "ur", "abb", "fanuc", "binary", "strict"

// Which part of a multi-part image a robot gets next (paper 002's sorting strategies).
enum class PartOrder {
  BestScore,  // "best_score": highest score first (the locator's order)
  ByLabel,    // "by_label": ascending label, best score first within a label
  LabelOnly,  // "label_only": only parts with RobotConfig::label, best score first
  Random,     // "random": the parts of an image in a random order (paper 002's random selection;
              // a permutation drawn from the cycle id, so a robot asking again gets the same)
};

enum class TriggerMode { Software, Hardware, FreeRun };

struct CameraConfig {
  std::string name = "cam0";
  std::string driver = "aravis";   // registry name: "aravis" or "replay"
  // How to find the camera: by IP address (preferred; required on loopback), else by
  // serial number (discovery, ~1 s), else by GenICam DeviceUserID. At least one is set
  // for "aravis"; with address and serial both set the serial is checked after opening.
  std::string address;
  std::string serial;
  std::string userName;
  int timeoutMs = 1000;            // ms, [50, 60000]: trigger -> frame before the frame counts as lost
  int retries = 1;                 // [0, 10]: re-triggers after a lost frame, within the cycle deadline
  double exposureUs = 5000;        // µs, [10, 1e8]; the camera's own range is checked on open
  double gain = -1;                // camera units (GenICam Gain/GainRaw); < 0 leaves the camera's value
  // GenICam name: Mono8, Mono10, Mono12, Mono16 (10/12/16 bit delivered as 16-bit samples),
  // BayerRG8, BayerGR8, BayerGB8, BayerBG8 (converted to Mono8 gray by the driver), or
  // Coord3D_C16 for a depth camera (z in mm through its Scan3d features; replay: a 3D data set).
  std::string pixelFormat = "Mono8";
  int roiX = 0, roiY = 0;          // px, >= 0: region offset on the sensor
  int roiWidth = 0, roiHeight = 0; // px, >= 0; 0 = the rest of the sensor from the offset
  int packetSize = 0;              // bytes, 0 (negotiate) or [576, 65000]: GigE Vision stream packet size
  int packetDelayNs = 0;           // ns, [0, 1e9]: GigE inter-packet delay (GevSCPD)
  int socketBufferBytes = 0;       // bytes, 0 (auto: one frame) or [65536, 1<<30]: UDP receive buffer
  bool packetResend = true;        // ask the camera to resend lost GVSP packets
  int bufferCount = 4;             // [2, 64]: preallocated frame buffers
  TriggerMode trigger = TriggerMode::Software;
  std::string triggerLine = "Line1";          // hardware trigger input (GenICam TriggerSource)
  std::string triggerActivation = "RisingEdge";  // GenICam TriggerActivation
  double triggerDelayUs = 0;       // µs, [0, 1e6]: line edge -> exposure (GenICam TriggerDelay)
  std::string replayFolder;        // driver "replay": folder of images served in name order
  bool replayLoop = true;          // driver "replay": start again after the last image
  int reconnectMinMs = 200;        // ms, [10, 60000]: first back-off after the camera drops out
  int reconnectMaxMs = 2000;       // ms, [reconnectMinMs, 600000]
  // A depth camera (pixel_format Coord3D_C16): it runs 3D jobs only, and a 2D camera 2D jobs
  // only (the config refuses a job of the other kind, naming the job and the camera).
  bool depth() const { return pixelFormat == "Coord3D_C16"; }
};
const char* triggerModeName(TriggerMode m);  // "software", "hardware", "free_run"

// Pinhole camera above the conveyor plane: the skeleton's "known model" mapping. Real
// calibration files replace it (docs/calibration.md).
struct PlaneModelConfig {
  double fx = 1000, fy = 1000;     // px, > 0
  double cx = 639.5, cy = 511.5;   // px
  // Camera pose in the robot base frame: optical centre at (x, y, z) mm, looking straight
  // down (camera z = -base z), image x axis rotated by rzDeg about base z.
  double camX = 0, camY = 0, camZ = 500;  // mm
  double camRzDeg = 0;                    // deg
  double planeZ = 0;                      // mm: conveyor plane height in the base frame
};

// Modbus client mode (docs/protocols.md): for PLCs that cannot write, vgrd polls a PLC
// input (the laser sensor), triggers on its debounced rising edge and writes the status and
// result block (the server's registers 16..45, same layout) to the PLC's holding registers.
enum class TriggerInputKind { DiscreteInput, Coil };
struct ModbusClientConfig {
  bool enabled = false;
  std::string host = "127.0.0.1";  // IPv4 address of the PLC (Modbus TCP server)
  std::uint16_t port = 502;
  int unitId = 1;                               // [0, 247]
  TriggerInputKind trigger = TriggerInputKind::DiscreteInput;  // FC02 or FC01
  int triggerAddress = 0;                       // [0, 65535], 0-based
  int statusAddress = 100;                      // [0, 65506]: first of 30 holding registers written
  int pollMs = 5;                               // ms, [1, 1000]: input poll period
  int debounceMs = 20;                          // ms, [0, 10000]: a level must hold this long to count
  int job = 0;                                  // job run on each trigger; 0 = the cell's first job
  int reconnectMs = 500;                        // ms, [10, 60000]: pause before reconnecting
};

// Connections one peer address may hold on a Modbus or robot port unless the config says
// (`max_clients_per_address`), capped at the port's max_clients: one host cannot take every
// slot (docs/protocols.md, "Connections").
inline constexpr int kDefaultMaxClientsPerAddress = 4;

struct ModbusConfig {
  bool enabled = true;
  std::string bind = "127.0.0.1";
  std::uint16_t port = 1502;
  WordOrder floatWordOrder = WordOrder::HighWordFirst;
  int maxClients = 8;                 // [1, 64]: PLC connections served at once
  int maxClientsPerAddress = kDefaultMaxClientsPerAddress;  // [1, maxClients]: from one address
  int idleTimeoutMs = 60000;          // ms, [0, 86400000]: a silent PLC connection is closed; 0 = never
  std::vector<std::string> allowedClients;  // numeric IPv4 addresses; empty = anyone
  // Numeric IPv4 addresses whose register writes (trigger, job, clear error) are served;
  // empty = every allowed client. Others may read; their writes get exception 02.
  std::vector<std::string> controlClients;
  bool requireTriggerEnable = false;  // true: triggers count only while CONTROL b3 is set
  ModbusClientConfig client;          // modbus.client
};

// Strict dialect (paper 002): the tokens the robot program uses, and the step timeout.
struct StrictConfig {
  std::string command = "MoveJ_pose";         // daemon -> robot; 1..64 printable, no spaces, ',' '#'
  std::string ready = "MoveJ_pose_wait_pos";  // robot -> daemon: "send the pose"
  std::string done = "MoveJ_pose_done";       // robot -> daemon: "move finished"
  std::string lineEnd;                        // "" (none), "\n" (lf) or "\r\n" (crlf) after each send
  int stepTimeoutMs = 10000;                  // ms, [50, 600000]: each of the two waits
  // Eye-in-hand snapshots (docs/protocols.md): the robot sends "<snapshot>(x,y,z,rx,ry,rz)"
  // with its flange pose and gets the four steps for the part, or "<none>(<status>)".
  // "" (default) = vgrd pushes every part of the robot's job (paper 002's push mode).
  std::string snapshot;                       // robot -> daemon; a token, no '(' or '['
  std::string none = "MoveJ_none";            // daemon -> robot; a token, no '(' or '['
};

struct RobotConfig {
  std::string name;
  Dialect dialect = Dialect::Ur;
  std::string bind = "127.0.0.1";
  std::uint16_t port = 0;
  int replyDeadlineMs = 1500;  // ms, [50, 60000]: a reply is always sent within this
  int job = 0;                 // [1, 32767], a job id of the cell; 0 = the cell's first job.
                               // What "GET" without a number (and the strict push) serves
                               // until the robot sends "JOB,<n>".
  int maxClients = 8;          // [1, 64]: connections at once
  int maxClientsPerAddress = kDefaultMaxClientsPerAddress;  // [1, maxClients]: from one address
  int staleAfterMs = 10000;    // ms, [100, 86400000]: when full, a connection idle this long with
                               // nothing in progress may be replaced by its address's newcomer
  std::vector<std::string> allowedClients;  // numeric IP addresses; empty = anyone
  std::vector<std::string> controlClients;  // numeric IP addresses that may send JOB/TRIG; empty = anyone
  int idleTimeoutMs = 0;       // ms, [0, 86400000]: a connection without a request is closed; 0 = never
  PartOrder partOrder = PartOrder::BestScore;
  int label = 0;               // [0, 32767]: the one label served with part_order label_only
  AbbRotation abbRotation = AbbRotation::EulerZyx;  // dialect abb only: "zyx" or "quaternion"
  // The part's label and its confidence in every reply (protocol/robot_codec.hpp formatReply
  // withLabel): ur 10 values, abb +2 fields (<= 80 chars), fanuc 85 bytes, binary 48 bytes.
  // Default false: replies exactly as before, for robot programs that read a fixed count.
  // Not for strict (its pose frame is the six values the robot moves to).
  bool replyLabel = false;
  StrictConfig strict;         // dialect strict only
  // What the robot program expects (docs/protocols.md, "Offsets and frames";
  // protocol/robot_frames.hpp): `deliver: pose` the part's pose in the user frame,
  // `deliver: offset` the offset from the job's taught reference in the dialect's
  // convention (abb, fanuc, binary: a displacement for PDispSet / Offset,PR[n]; ur, strict:
  // R^-1 P for pose_trans). `frame`: the user / work-object frame the program moves in,
  // its pose in the base frame (x, y, z mm; rz, ry, rx deg, Z-Y-X) and its name as the
  // robot program calls it (journal). Absent: the base frame, named "base".
  Delivery delivery = Delivery::Pose;
  std::string frameName = "base";  // 1..32 printable ASCII characters
  Pose baseFromUser;               // T_base_user
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
  bool referenceGiven = false; // `reference` written (in the cell entry or the folder's job.yaml)
  // `limits` (cell entry, also for a job with a folder: the work area belongs to the cell):
  // offset from the reference and absolute pose; a part outside is not delivered (-9).
  JobLimits limits;
  // A job folder (`vgr teach`, docs/localization.md), resolved against the config file's
  // folder; empty = the moments method with the keys above. With a folder, the method
  // (unless `method` is given here), part_height_mm and reference come from its job.yaml,
  // and vgrd builds the method at start.
  std::string folder;
  // The folder's job.yaml says `kind: 3d` (config/job3d.hpp, docs/3d.md): a part model found
  // in a depth frame (vision/cloud), the pose with all six degrees of freedom. Such a job has
  // no taught reference (its offsets are its poses; robots in offset mode are refused), no
  // `method` and no `angle_offset_deg`; it needs a depth camera.
  bool depth = false;
};

struct SimConfig {
  std::uint64_t seed = 1;
  int width = 1280, height = 1024;  // px
  double noiseSigma = 2.0;          // gray levels
  std::string serial = "VGR-SIM-0";
  // What the emulator shows: `plate` (the skeleton's flat plate, SceneRenderer), `part` (the
  // same part textured, with holes and marks) or `multi` (a part with `levels` height levels),
  // both from PartSceneRenderer, the dataset renderer (docs/datasets.md).
  std::string scene = "plate";
  int levels = 3;                // [2, 4], multi only
  double angleRangeDeg = 180;    // part/multi: rotation drawn in [-range, range], deg
  int parts = 1;                 // part/multi: parts per image, [1, 16]
  int clutter = 0;               // part/multi: distractor shapes per image, [0, 64]
  // Commissioning (docs/commissioning.md): `still: true` shows frame 1's scene in every
  // frame (the part does not move; the sensor noise still changes per frame), for
  // `vgr repeatability`. `camera_shift` moves the rendered camera from where `model` (and
  // the calibration) says it is: a knocked camera, for the drift monitor and
  // `vgr calibrate verify`. `fiducial`: a bright disk fixed on the belt (base frame).
  bool still = false;
  double shiftXMm = 0, shiftYMm = 0, shiftZMm = 0, shiftRzDeg = 0;  // camera_shift: mm, deg
  double fiducialXMm = 0, fiducialYMm = 0;  // fiducial: centre on the plane, base frame, mm
  double fiducialDiameterMm = 0;            // mm, 0 = no fiducial, else [2, 100]
  // part: several part classes mixed in every frame (sim/part_scene.hpp PartModel::byName
  // names, e.g. [ring, square, rect_notch]); a part's truth then carries `label`, its 1-based
  // index in this list (the label a classifier trained on these classes gives it). Empty =
  // the scene's one part. Names are checked by the renderer (vgr-sim-camera, vgr demo).
  std::vector<std::string> classes;
};

// Calibration files (docs/calibration.md) vgrd maps pixels with instead of `model`. Paths
// relative to the config file's folder. Either the camera-plane set (intrinsics + handeye +
// plane, all three) or paper 001's multi-height map (multiheight alone), or the section
// absent. A job whose calibration is missing or inconsistent gets -6 NOT_CALIBRATED.
struct CalibrationFilesConfig {
  bool enabled = false;    // true when the section is present
  std::string intrinsics;  // intrinsics.yaml (vgr calibrate intrinsics)
  std::string handeye;     // handeye.yaml, eye-to-hand (vgr calibrate handeye)
  std::string plane;       // plane.yaml (vgr calibrate plane)
  // A depth camera (CameraConfig::depth()) needs handeye.yaml alone (`vgr calibrate handeye
  // --cloud`, eye-to-hand or eye-in-hand): it sends its intrinsics with every frame and a 3D
  // pose needs no work plane, so intrinsics, plane, multiheight and drift are refused there.
  std::string multiHeight; // multiheight.yaml (paper 001, section 4.1); excludes the three above
  // check.yaml (vgr calibrate verify --store, vision/calib/check_file.hpp): the stored
  // positions of the check targets (a fixed fiducial, a check part, the plate put back).
  std::string check;
  // vgrd's drift monitor (daemon/drift_monitor.hpp), on when the `drift` section is given;
  // needs `check` with a fiducial. The fiducial is measured in every frame; the alarm is up
  // while the median of the last `window` residuals is above threshold_mm (or the fiducial
  // was not seen in `window` frames in a row).
  struct Drift {
    bool enabled = false;
    double thresholdMm = 0.3;  // mm, (0, 100]
    int window = 5;            // frames, [1, 100]
    bool refuse = false;       // on_alarm: warn (false) | refuse (true: every cycle -6 while the alarm is up)
  } drift;
};

// vgrd's HTTP server (daemon/web_server.hpp): /metrics for Prometheus and the
// commissioning page with its JSON and WebSocket API (docs/commissioning.md), read-only
// unless `actions` is on. Off unless the `web` section is present (then on unless
// `enabled: false`).
struct WebConfig {
  bool enabled = false;
  std::string bind = "127.0.0.1";  // numeric IPv4/IPv6 address; 0.0.0.0 for a plant network
  std::uint16_t port = 8080;       // [1, 65535]
  bool page = true;                // the commissioning page, /api/... and /ws; false = /metrics only
  // Operator actions (POST /api/trigger, /api/job) from the addresses in allowedClients
  // only; others get 403, and every client gets 405 while actions are off.
  bool actions = false;
  std::vector<std::string> allowedClients;  // numeric IP addresses (normalised); required with actions
  int liveMaxWidth = 1280;         // px, [160, 8192]: the page's images are scaled down to this width
};

// The image archive (daemon/image_archive.hpp, docs/commissioning.md): the frames of failed
// cycles and every N-th good one as lossless PNG (the 8-bit image the locator saw), each
// with its journal line beside it, under a disk quota (oldest deleted first). Off unless
// the `archive` section is present (then on unless `enabled: false`).
struct ArchiveConfig {
  bool enabled = false;
  std::string dir;                 // "" = "archive" next to the journal (vgrd's --journal included); relative: to the config file's folder
  std::uint64_t quotaBytes = 1000000000;  // archive.quota_mb (MB = 10^6 bytes), [1, 10^7] MB
  int everyNthGood = 100;          // [0, 10^6]: keep every N-th OK cycle's frame too; 0 = failed ones only
  int queue = 8;                   // frames, [1, 64]: waiting for the disk; a frame beyond is dropped (counted)
};

// vgrd's MQTT sink (daemon/mqtt_sink.hpp, docs/plant.md): every result as JSON on
// <prefix>/<cell>/result (QoS 1), a retained <prefix>/<cell>/status with a Last Will. Off
// unless the `mqtt` section is present (then on unless `enabled: false`).
struct MqttConfig {
  bool enabled = false;
  std::string host = "127.0.0.1";  // broker host name or address
  std::uint16_t port = 1883;       // [1, 65535]
  std::string prefix = "vgr";      // topic prefix: non-empty, no '#', '+' or trailing '/'
  std::string clientId;            // "" = "vgrd-<cell.name>"
  std::string username;            // "" = anonymous
  std::string password;
  std::string tlsCaFile;           // tls.ca_file: TLS on when set
  std::string tlsCertFile;         // tls.cert_file + tls.key_file: client certificate (both or neither)
  std::string tlsKeyFile;
  bool tlsInsecure = false;        // tls.insecure: skip the host name check (testing only)
  int keepaliveS = 30;             // s, [5, 3600]
  int queueCapacity = 1000;        // results, [1, 1000000]: waiting while the broker is away; the oldest is dropped (counted)
  int reconnectMinS = 1;           // s, [1, 3600]: first back-off, doubling up to reconnect_max_s
  int reconnectMaxS = 30;          // s, [reconnect_min_s, 3600]
};
// Of every cycle's deadline, the cycle runner keeps kProcessingReserveMs for locating and
// publishing and gives the camera the rest; a deadline must leave the camera at least
// kMinCameraTimeMs.
inline constexpr int kProcessingReserveMs = 150;  // ms
inline constexpr int kMinCameraTimeMs = 100;      // ms
inline constexpr int kMinCycleDeadlineMs = kProcessingReserveMs + kMinCameraTimeMs;

struct CellConfig {
  std::string sourcePath;           // file it was loaded from
  std::string name = "cell";
  std::string journalPath = "/var/lib/vgr/journal.jsonl";
  long long journalMaxBytes = 100LL << 20;  // bytes, [65536, 2^40]: the journal rotates at this size
  int journalFiles = 9;             // [1, 1000]: rotated journals kept (journal.1 .. journal.N)
  int journalSyncMs = 1000;         // ms, [-1, 3600000]: fdatasync at most this often; 0 = every record, -1 = never
  std::string logLevel = "info";
  int cycleDeadlineMs = 1500;       // ms, [kMinCycleDeadlineMs = 250, 60000]: trigger -> result, always answered
  CameraConfig camera;
  PlaneModelConfig model;           // required unless the `calibration` section is present
  ModbusConfig modbus;
  std::vector<RobotConfig> robots;
  std::vector<JobConfig> jobs;
  SimConfig sim;
  CalibrationFilesConfig calibration;  // optional section `calibration`
  WebConfig web;                       // optional section `web`
  ArchiveConfig archive;               // optional section `archive`
  MqttConfig mqtt;                     // optional section `mqtt`

  const JobConfig* findJob(int id) const;
};

// Loads and validates. Errors carry Status::BadArgument and a one-line message
// "FILE:LINE: key 'camera.timeout_ms': expected an integer in [50, 60000], got 'abc'".
Result<CellConfig> loadCellConfig(const std::string& path);
Result<CellConfig> parseCellConfig(const std::string& yamlText, const std::string& sourceName);

// The example simulated cell, embedded at build time from config/examples/sim-cell.yaml.
const std::string& embeddedSimCellYaml();
// Its calibration files, embedded from config/examples/sim-calib/ (made by
// scripts/calibrate-sim-cell.sh from plate images served by the camera emulator).
const std::string& embeddedSimCalibIntrinsics();
const std::string& embeddedSimCalibHandEye();
const std::string& embeddedSimCalibPlane();

// The simulated 3D cell (`vgr demo --3d`), embedded from config/examples/: sim-cell-3d.yaml,
// its depth camera's hand-eye (sim-calib-3d/handeye.yaml, made by
// scripts/calibrate-sim-cell-3d.sh), that calibration set's truth (sim-calib-3d/truth.yaml:
// where the simulated camera really is) and its 3D job's job.yaml (sim-job-3d/job.yaml; the
// model.ply beside it comes from the depth renderer).
const std::string& embeddedSimCell3dYaml();
const std::string& embeddedSimCalib3dHandEye();
const std::string& embeddedSimCalib3dTruth();
const std::string& embeddedSimJob3dYaml();

// Writes `yamlText` (default: the embedded example) as DIR/sim-cell.yaml and the example's
// calibration files as DIR/sim-calib/{intrinsics,handeye,plane}.yaml, where the example's
// `calibration` section finds them. Creates DIR. Returns the config file's path.
Result<std::string> writeSimCell(const std::string& dir, const std::string& yamlText = embeddedSimCellYaml());

}  // namespace vgr::config
