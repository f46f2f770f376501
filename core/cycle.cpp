#include "core/cycle.hpp"

namespace vgr {

const char* triggerSourceName(TriggerSource source) {
  switch (source) {
    case TriggerSource::Modbus: return "modbus";
    case TriggerSource::Robot: return "robot";
    case TriggerSource::Operator: return "operator";
  }
  return "modbus";
}

}  // namespace vgr
