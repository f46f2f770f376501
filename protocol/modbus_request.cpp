#include "protocol/modbus_request.hpp"

#include <modbus.h>

#include <poll.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace vgr::protocol {

namespace {

constexpr std::size_t kMbapLength = 7;  // transaction id, protocol id, length, unit id

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

}  // namespace

static_assert(kModbusTcpMaxAdu == MODBUS_TCP_MAX_ADU_LENGTH);

AduScan scanAdu(std::span<const std::uint8_t> buffered) {
  AduScan s;
  if (buffered.size() >= 4 && be16(&buffered[2]) != 0) {
    s.kind = AduScan::Kind::Malformed;
    return s;
  }
  if (buffered.size() < 6) return s;
  const std::size_t length = be16(&buffered[4]);  // unit id + PDU
  if (length < 2 || 6 + length > kModbusTcpMaxAdu) {
    s.kind = AduScan::Kind::Malformed;
    return s;
  }
  if (buffered.size() < 6 + length) return s;
  s.kind = AduScan::Kind::Complete;
  s.length = 6 + length;
  return s;
}

FrameCheck checkFrame(std::span<const std::uint8_t> frame) {
  FrameCheck c;
  // MBAP: transaction id (2), protocol id (2, must be 0), length (2, bytes that follow),
  // unit id (1), then the PDU. libmodbus checks none of this on the server side.
  if (frame.size() < kMbapLength + 1 || be16(&frame[2]) != 0 || be16(&frame[4]) != frame.size() - 6) return c;
  const std::span<const std::uint8_t> pdu = frame.subspan(kMbapLength);
  // The PDU's length as its function code's fields give it (what libmodbus reads); a
  // frame whose MBAP length says otherwise is dropped. Function codes libmodbus does not
  // serve, and FC17 (it reports the library's version), get exception 01.
  std::size_t expected = 0;
  switch (pdu[0]) {
    case MODBUS_FC_READ_COILS:
    case MODBUS_FC_READ_DISCRETE_INPUTS:
    case MODBUS_FC_READ_HOLDING_REGISTERS:
    case MODBUS_FC_READ_INPUT_REGISTERS:
    case MODBUS_FC_WRITE_SINGLE_COIL:
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
      expected = 5;
      break;
    case MODBUS_FC_WRITE_MULTIPLE_COILS:
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
      expected = pdu.size() >= 6 ? 6 + std::size_t{pdu[5]} : 6;
      break;
    case MODBUS_FC_MASK_WRITE_REGISTER:
      expected = 7;
      break;
    case MODBUS_FC_WRITE_AND_READ_REGISTERS:
      expected = pdu.size() >= 10 ? 10 + std::size_t{pdu[9]} : 10;
      break;
    default:
      c.verdict = FrameVerdict::Unsupported;
      return c;
  }
  if (pdu.size() != expected) return c;
  std::uint32_t address = 0, count = 0;
  switch (pdu[0]) {
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
    case MODBUS_FC_MASK_WRITE_REGISTER:
      c.writes = true;
      address = be16(&pdu[1]);
      count = 1;
      break;
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
      c.writes = true;
      address = be16(&pdu[1]), count = be16(&pdu[3]);
      break;
    case MODBUS_FC_WRITE_AND_READ_REGISTERS:
      c.writes = true;
      address = be16(&pdu[5]), count = be16(&pdu[7]);
      break;
    default:
      break;
  }
  c.verdict = c.writes && !modbus::isWritable(address, count) ? FrameVerdict::RejectAddress : FrameVerdict::Serve;
  return c;
}

struct ModbusRequestHandler::Ctx {
  modbus_t* ctx = nullptr;
  ~Ctx() {
    if (ctx == nullptr) return;
    modbus_set_socket(ctx, -1);  // the caller owns the descriptors
    modbus_free(ctx);
  }
};

ModbusRequestHandler::ModbusRequestHandler(std::chrono::microseconds byteTimeout)
    : ctx_(std::make_unique<Ctx>()), byteTimeout_(byteTimeout) {
  // The context only parses and answers requests on sockets the caller accepted; the
  // address is never used.
  ctx_->ctx = modbus_new_tcp("127.0.0.1", 502);
  if (ctx_->ctx == nullptr) return;
  // Framing is ours (scanAdu()), so libmodbus' byte and indication timeouts never apply.
  modbus_set_error_recovery(ctx_->ctx, MODBUS_ERROR_RECOVERY_NONE);
  // libmodbus 3.1.6 modbus_reply() sleeps for the RESPONSE timeout (default 500 ms) before
  // answering some invalid requests (e.g. FC03 with count 0: "illegal data value"), on the
  // server thread, under our map lock. Found by fuzz_modbus_adu (200 exec/s). 1 µs is the
  // smallest value it accepts.
  modbus_set_response_timeout(ctx_->ctx, 0, 1);
}

ModbusRequestHandler::~ModbusRequestHandler() = default;

bool ModbusRequestHandler::valid() const { return ctx_->ctx != nullptr; }

int ModbusRequestHandler::receive(int fd, ModbusFrame& frame) {
  // Reads exactly one ADU: the MBAP header first, then the length it announces.
  std::size_t have = 0, want = 6;
  const int waitMs = static_cast<int>(std::max<std::int64_t>(1, byteTimeout_.count() / 1000));
  for (;;) {
    const AduScan scan = scanAdu(std::span<const std::uint8_t>(frame.data(), have));
    if (scan.kind == AduScan::Kind::Malformed) {
      lastError_ = "malformed frame";
      return -1;
    }
    if (scan.kind == AduScan::Kind::Complete) return static_cast<int>(scan.length);
    if (have >= 6) want = 6 + be16(&frame[4]);
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, waitMs) <= 0) {
      lastError_ = have == 0 ? "idle" : "stalled mid-frame";
      return -1;
    }
    const auto n = ::recv(fd, frame.data() + have, want - have, 0);
    if (n <= 0) {
      lastError_ = n == 0 || errno == ECONNRESET ? std::string("closed by peer") : "receive failed: " + std::string(std::strerror(errno));
      return -1;
    }
    have += static_cast<std::size_t>(n);
  }
}

ModbusRequestHandler::Outcome ModbusRequestHandler::handle(int fd, const ModbusFrame& frame, int length, ModbusMap& map,
                                                           const ModbusMap::TriggerFn& onTrigger, bool mayWrite) {
  Outcome out;
  if (length <= 0 || static_cast<std::size_t>(length) > frame.size()) {
    out.keep = false;
    out.dropReason = "malformed frame";
    return out;
  }
  out.check = checkFrame(std::span<const std::uint8_t>(frame.data(), static_cast<std::size_t>(length)));
  if (out.check.verdict == FrameVerdict::Serve && out.check.writes && !mayWrite) {
    out.check.verdict = FrameVerdict::RejectAddress;  // read-only for this client
    out.writeRefused = true;
  }
  modbus_set_socket(ctx_->ctx, fd);
  switch (out.check.verdict) {
    case FrameVerdict::Drop:
      out.keep = false;
      out.dropReason = "malformed frame";
      return out;
    case FrameVerdict::Unsupported:
      if (modbus_reply_exception(ctx_->ctx, frame.data(), MODBUS_EXCEPTION_ILLEGAL_FUNCTION) < 0) {
        out.keep = false;
        out.dropReason = "send failed: " + std::string(modbus_strerror(errno));
      }
      return out;
    case FrameVerdict::RejectAddress:
      if (modbus_reply_exception(ctx_->ctx, frame.data(), MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS) < 0) {
        out.keep = false;
        out.dropReason = "send failed: " + std::string(modbus_strerror(errno));
      }
      return out;
    case FrameVerdict::Serve:
      break;
  }
  auto holding = map.holdingRegisters();
  auto input = map.inputRegisters();
  modbus_mapping_t mapping{};
  mapping.nb_registers = static_cast<int>(holding.size());
  mapping.tab_registers = holding.data();
  mapping.nb_input_registers = static_cast<int>(input.size());
  mapping.tab_input_registers = input.data();
  const int sent = modbus_reply(ctx_->ctx, frame.data(), length, &mapping);
  const int sendErr = errno;
  if (out.check.writes) out.events = map.onHoldingWritten(onTrigger);
  if (sent < 0) {
    out.keep = false;
    out.dropReason = "send failed: " + std::string(modbus_strerror(sendErr));
  }
  return out;
}

}  // namespace vgr::protocol
