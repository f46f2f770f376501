#include "core/status.hpp"

namespace vgr {

std::string_view statusName(Status s) {
  switch (s) {
    case Status::Ok: return "OK";
    case Status::NoPartFound: return "NO_PART_FOUND";
    case Status::ResultNotReady: return "RESULT_NOT_READY";
    case Status::NoNewTrigger: return "NO_NEW_TRIGGER";
    case Status::RetryNewViewpoint: return "RETRY_NEW_VIEWPOINT";
    case Status::UnknownCommand: return "UNKNOWN_COMMAND";
    case Status::BadArgument: return "BAD_ARGUMENT";
    case Status::BusyOverrun: return "BUSY_OVERRUN";
    case Status::CameraError: return "CAMERA_ERROR";
    case Status::ProcessingTimeout: return "PROCESSING_TIMEOUT";
    case Status::NotCalibrated: return "NOT_CALIBRATED";
    case Status::JobNotFound: return "JOB_NOT_FOUND";
    case Status::Internal: return "INTERNAL";
    case Status::OffsetOutOfLimits: return "OFFSET_OUT_OF_LIMITS";
    case Status::NotPermitted: return "NOT_PERMITTED";
  }
  return "INTERNAL";
}

}  // namespace vgr
