// Error-frame decoding after linux/can/error.h (class bits in the id, details in data[]).
#include "ndsid/can/error_frame.h"

#include <linux/can/error.h>

#include <cstdio>

namespace ndsid::can {
namespace {

struct BitName {
  uint32_t bit;
  const char* name;
};

void AppendBits(std::string& out, uint32_t value, std::initializer_list<BitName> names) {
  bool first = true;
  for (const auto& [bit, name] : names) {
    if ((value & bit) == 0) continue;
    out += first ? "" : ",";
    out += name;
    first = false;
  }
  if (first) out += "unspecified";
}

}  // namespace

bool IsBusOffError(const CanFrame& frame) noexcept {
  return frame.error() && (frame.id & CAN_ERR_BUSOFF) != 0;
}

std::string DescribeErrorFrame(const CanFrame& frame) {
  if (!frame.error()) return "not an error frame";
  const uint32_t cls = frame.id;
  const auto& d = frame.data;
  std::string out;
  auto part = [&out](const char* text) {
    if (!out.empty()) out += "; ";
    out += text;
  };
  if (cls & CAN_ERR_TX_TIMEOUT) part("tx timeout");
  if (cls & CAN_ERR_LOSTARB) {
    part("lost arbitration at bit ");
    out += d[0] == CAN_ERR_LOSTARB_UNSPEC ? "?" : std::to_string(d[0]);
  }
  if (cls & CAN_ERR_CRTL) {
    part("controller: ");
    AppendBits(out, d[1], {{CAN_ERR_CRTL_RX_OVERFLOW, "rx-overflow"},
                           {CAN_ERR_CRTL_TX_OVERFLOW, "tx-overflow"},
                           {CAN_ERR_CRTL_RX_WARNING, "rx-warning"},
                           {CAN_ERR_CRTL_TX_WARNING, "tx-warning"},
                           {CAN_ERR_CRTL_RX_PASSIVE, "rx-error-passive"},
                           {CAN_ERR_CRTL_TX_PASSIVE, "tx-error-passive"},
                           {CAN_ERR_CRTL_ACTIVE, "back-to-error-active"}});
  }
  if (cls & CAN_ERR_PROT) {
    part("protocol violation: ");
    AppendBits(out, d[2], {{CAN_ERR_PROT_BIT, "single-bit"},
                           {CAN_ERR_PROT_FORM, "frame-format"},
                           {CAN_ERR_PROT_STUFF, "bit-stuffing"},
                           {CAN_ERR_PROT_BIT0, "dominant-bit"},
                           {CAN_ERR_PROT_BIT1, "recessive-bit"},
                           {CAN_ERR_PROT_OVERLOAD, "bus-overload"},
                           {CAN_ERR_PROT_ACTIVE, "active-error-announcement"},
                           {CAN_ERR_PROT_TX, "during-tx"}});
    char location[24];
    std::snprintf(location, sizeof location, " at location 0x%02X", d[3]);
    out += location;
  }
  if (cls & CAN_ERR_TRX) {
    char text[40];
    std::snprintf(text, sizeof text, "transceiver status 0x%02X", d[4]);
    part(text);
  }
  if (cls & CAN_ERR_ACK) part("no ack on transmission");
  if (cls & CAN_ERR_BUSOFF) part("bus-off");
  if (cls & CAN_ERR_BUSERROR) part("bus error");
  if (cls & CAN_ERR_RESTARTED) part("controller restarted");
#ifdef CAN_ERR_CNT
  const bool counters = (cls & CAN_ERR_CNT) != 0;
#else
  const bool counters = false;
#endif
  if (counters || d[6] != 0 || d[7] != 0) {
    char text[48];
    std::snprintf(text, sizeof text, "tx/rx error counters %u/%u", d[6], d[7]);
    part(text);
  }
  if (out.empty()) part("unknown error class");
  return out;
}

}  // namespace ndsid::can
