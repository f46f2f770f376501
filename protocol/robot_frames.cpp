#include "protocol/robot_frames.hpp"

namespace vgr::protocol {

OffsetConvention offsetConvention(Dialect dialect) {
  switch (dialect) {
    case Dialect::Ur:
    case Dialect::Strict:
      return OffsetConvention::ReferenceRelative;
    case Dialect::Abb:
    case Dialect::Fanuc:
    case Dialect::Binary:
      return OffsetConvention::Displacement;
  }
  return OffsetConvention::Displacement;
}

Pose deliveredPose(Dialect dialect, const RobotFrame& frame, const Pose& reference, const Pose& part) {
  const Pose userFromBase = inverse(frame.baseFromUser);
  const Pose partInUser = compose(userFromBase, part);  // U^-1 P
  if (frame.delivery == Delivery::Pose) return partInUser;
  if (offsetConvention(dialect) == OffsetConvention::ReferenceRelative) return compose(inverse(reference), part);  // R^-1 P
  const Pose refInUser = compose(userFromBase, reference);  // U^-1 R
  return compose(partInUser, inverse(refInUser));           // (U^-1 P)(U^-1 R)^-1
}

}  // namespace vgr::protocol
