// Deliberately crosses the layering: config/ may not include vision/.
#pragma once

#include "core/ok.hpp"
#include "vision/x.hpp"
