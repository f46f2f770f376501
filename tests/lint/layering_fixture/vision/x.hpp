#pragma once

#include "core/ok.hpp"
