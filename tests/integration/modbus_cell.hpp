// Moved to tests/support/modbus_cell.hpp (with SimCell, tests/support/sim_cell.hpp). This
// forward keeps `#include "modbus_cell.hpp"` building, with the headers the old file brought
// along; include "tests/support/modbus_cell.hpp" in new code. To be removed.
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/modbus_cell.hpp"
