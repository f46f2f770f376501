// One status table for robots, Modbus, journal and web (ARCHITECTURE.md, "Status codes").
#pragma once

#include <cstdint>
#include <string_view>

namespace vgr {

enum class Status : std::int16_t {
  Ok = 0,
  NoPartFound = 1,
  ResultNotReady = 2,
  NoNewTrigger = 3,
  // A 3D job (paper 004): something consistent with the view covers too little of what this
  // viewpoint should show of the part (fitness below f_l): move the camera and trigger again.
  // No pose; not an error (the PLC's ERROR bit stays off). docs/3d.md "Outcomes".
  RetryNewViewpoint = 4,
  UnknownCommand = -1,
  BadArgument = -2,
  BusyOverrun = -3,
  CameraError = -4,
  ProcessingTimeout = -5,
  NotCalibrated = -6,
  JobNotFound = -7,
  Internal = -8,
  OffsetOutOfLimits = -9,
  NotPermitted = -10,  // a control request (robot JOB/TRIG) from an address not in control_clients
};

// Every status, in the table's order: the one list that code enumerating statuses (the
// metrics' series, tests) uses, so a new status cannot be forgotten there (status_test checks
// it against statusName).
inline constexpr Status kAllStatuses[] = {
    Status::Ok,           Status::NoPartFound,     Status::ResultNotReady,    Status::NoNewTrigger,
    Status::RetryNewViewpoint, Status::UnknownCommand, Status::BadArgument,   Status::BusyOverrun,
    Status::CameraError,  Status::ProcessingTimeout, Status::NotCalibrated,   Status::JobNotFound,
    Status::Internal,     Status::OffsetOutOfLimits, Status::NotPermitted};

// Upper-case name as in the table ("CAMERA_ERROR").
std::string_view statusName(Status s);
constexpr int statusCode(Status s) { return static_cast<int>(s); }

}  // namespace vgr
