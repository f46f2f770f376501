// The wire choices a cell config makes for the protocol layer, owned here and used by
// config/ (which parses them from cell.yaml) and by the codecs and servers: the robot
// dialect of an endpoint and the word order of a Modbus float32. Plain enums, no I/O.
#pragma once

#include <optional>
#include <string_view>

namespace vgr::protocol {

// One wire dialect per robot endpoint, chosen in the cell config.
enum class Dialect {
  Ur,      // URScript client: socket_send_line("GET,<job>") / socket_read_ascii_float(8)
  Abb,     // RAPID client: SocketSend \Str:="GET,<job>#" / SocketReceive \Str (<= 80 chars)
  Fanuc,   // KAREL client: WRITE "GET,<job>" + CR / READ up to the line end, fixed columns
  Binary,  // int32 big-endian frames (URCap socket_read_binary_integer, RAPID \Network)
  Strict,  // paper 002 four-step push: <CMD>, <CMD>_wait_pos, pose frame, <CMD>_done
};

// "ur", "abb", "fanuc", "binary" or "strict" (lower case, exactly as written in
// cell.yaml); nullopt otherwise.
std::optional<Dialect> parseDialect(std::string_view text);
// The cell.yaml spelling.
std::string_view dialectName(Dialect dialect);

// How the abb dialect writes a rotation (cell.yaml robots[].abb_rotation): Z-Y-X Euler
// degrees rz, ry, rx for OrientZYX (default), or the quaternion q1..q4 (w, x, y, z) of a
// RAPID orient. Requests carrying a pose may use either, whatever this says.
enum class AbbRotation { EulerZyx, Quaternion };
// "zyx" or "quaternion" (the cell.yaml spelling); nullopt otherwise.
std::optional<AbbRotation> parseAbbRotation(std::string_view text);
std::string_view abbRotationName(AbbRotation rotation);
// What a robot endpoint receives for a part (docs/protocols.md, "Offsets and frames";
// protocol/robot_frames.hpp does the arithmetic): the part's pose in the endpoint's user
// frame, or the offset from the job's taught reference in the dialect's convention.
enum class Delivery { Pose, Offset };
// "pose" or "offset" (cell.yaml `robots[].deliver`); nullopt otherwise.
std::optional<Delivery> parseDelivery(std::string_view text);
std::string_view deliveryName(Delivery delivery);

// Word order of a float32 spread over two registers. HighWordFirst = "ABCD": the register
// at the lower address holds the sign/exponent half, each register big-endian on the wire.
enum class WordOrder { HighWordFirst, LowWordFirst };

}  // namespace vgr::protocol
