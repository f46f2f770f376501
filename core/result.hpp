// Errors as values where failure is expected (STYLE.md rule 5).
#pragma once

#include <expected>
#include <string>
#include <utility>

#include "core/status.hpp"

namespace vgr {

struct Error {
  Status code = Status::Internal;
  std::string message;  // with context: which camera, file, key, ...
};

template <class T>
using Result = std::expected<T, Error>;

inline std::unexpected<Error> fail(Status code, std::string message) {
  return std::unexpected<Error>(Error{code, std::move(message)});
}

}  // namespace vgr
