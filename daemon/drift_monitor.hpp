// vgrd's calibration drift monitor (docs/calibration.md, "Drift monitor"): the fixed
// fiducial of the cell's check file (vision/calib/check_file.hpp) is located in every
// frame a cycle grabs (vision/calib/fiducial.hpp), its centre mapped with the cell's
// calibration at its height, and the distance to its stored position is the mapping's
// residual there: 0 while the camera, the lens and the calibration still agree; it grows
// when the camera is knocked, a mount creeps or the lens is touched.
//
// Alarm: up while the median of the last `window` residuals (at least min(window, 3) of
// them) exceeds `threshold_mm`, or when the fiducial was not seen in `window` frames in a
// row (covered, or the camera moved so far that the mark left its window: the calibration
// can no longer be vouched for); down again when neither holds. A change of state is one
// log line (warn up, info down); every cycle's residual and state go into its
// CycleResult (journal `drift_mm`, `drift_alarm`; metrics vgr_calibration_drift_mm,
// vgr_calibration_drift_alarm). With `on_alarm: refuse` the cycle runner answers -6
// NOT_CALIBRATED while the alarm is up.
// Thread: measure() on the cycle thread only (not reentrant); snapshot() from any thread
// (a short lock; the page's status section, daemon/vgrd_app.cpp). No allocation per frame
// beyond the fiducial search's few KB.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "vision/calib/check_file.hpp"
#include "vision/calib/fiducial.hpp"
#include "vision/calib/pixel_mapping.hpp"

namespace cv {
class Mat;
}

namespace vgr::daemon {

class DriftMonitor {
 public:
  DriftMonitor(const config::CalibrationFilesConfig::Drift& cfg, const vision::calib::CheckFile::Fiducial& fiducial);

  // Measures the fiducial in `gray` (CV_8UC1, the frame the cycle locates in) and sets
  // r.driftMonitored, r.driftMm (NaN when not seen) and r.driftAlarm.
  void measure(const cv::Mat& gray, const vision::calib::PixelMapping& mapping, CycleResult& r);

  bool alarm() const { return alarm_; }

  // The state after the last frame, for the commissioning page (any thread).
  struct Snapshot {
    double residualMm = 0;  // the last frame's residual; NaN when not seen (or no frame yet)
    double medianMm = 0;    // median of the window; NaN before the first seen frame
    bool alarm = false;
    std::string reason;     // why the alarm is up; empty when down
    std::uint64_t seen = 0, missed = 0;  // frames with and without the fiducial
  };
  Snapshot snapshot() const;
  const config::CalibrationFilesConfig::Drift& config() const { return cfg_; }
  // Why the alarm is up ("median residual 0.512 mm over 5 frames above 0.3 mm", "fiducial
  // not seen in 5 frames in a row"); empty when it is down.
  const std::string& reason() const { return reason_; }
  std::string describe() const;  // for the start-up log

 private:
  config::CalibrationFilesConfig::Drift cfg_;
  vision::calib::CheckFile::Fiducial fiducial_;
  vision::calib::FiducialSearch search_;
  std::vector<double> ring_;     // the last `window` residuals, mm
  std::vector<double> scratch_;  // median
  std::size_t count_ = 0, next_ = 0;
  int missesInRow_ = 0;
  std::uint64_t seen_ = 0, missed_ = 0;
  bool alarm_ = false;
  std::string reason_;
  mutable std::mutex snapMutex_;  // guards snap_
  Snapshot snap_;
};

}  // namespace vgr::daemon
