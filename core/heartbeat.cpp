#include "core/heartbeat.hpp"

#include <pthread.h>

namespace vgr {

void nameThisThread(const char* name) noexcept { pthread_setname_np(pthread_self(), name); }

}  // namespace vgr
