// DescribeErrorFrame: the log text operators read when the bus misbehaves.
#include <gtest/gtest.h>
#include <linux/can/error.h>

#include "ndsid/can/error_frame.h"

namespace ndsid::can {
namespace {

CanFrame ErrorFrame(uint32_t classes, std::array<uint8_t, 8> data = {}) {
  CanFrame f;
  f.flags = kFlagError;
  f.id = classes;
  f.len = 8;
  std::copy(data.begin(), data.end(), f.data.begin());
  return f;
}

TEST(ErrorFrame, BusOffIsNamedAndRecognised) {
  const CanFrame f = ErrorFrame(CAN_ERR_BUSOFF);
  EXPECT_EQ(DescribeErrorFrame(f), "bus-off");
  EXPECT_TRUE(IsBusOffError(f));
  EXPECT_FALSE(IsBusOffError(ErrorFrame(CAN_ERR_CRTL)));
}

TEST(ErrorFrame, ControllerProblemsAndCountersAreDecoded) {
  const CanFrame f = ErrorFrame(CAN_ERR_CRTL | CAN_ERR_CNT,
                                {0, CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_WARNING, 0, 0, 0, 0, 97, 128});
  EXPECT_EQ(DescribeErrorFrame(f), "controller: tx-warning,rx-error-passive; tx/rx error counters 97/128");
}

TEST(ErrorFrame, ProtocolViolationNamesTypeAndLocation) {
  const CanFrame f = ErrorFrame(CAN_ERR_PROT | CAN_ERR_BUSERROR, {0, 0, CAN_ERR_PROT_STUFF, CAN_ERR_PROT_LOC_ACK, 0, 0, 0, 0});
  EXPECT_EQ(DescribeErrorFrame(f), "protocol violation: bit-stuffing at location 0x19; bus error");
}

TEST(ErrorFrame, DataFrameIsNotDescribedAsError) {
  CanFrame f;
  f.id = CAN_ERR_BUSOFF;
  EXPECT_EQ(DescribeErrorFrame(f), "not an error frame");
  EXPECT_FALSE(IsBusOffError(f));
}

}  // namespace
}  // namespace ndsid::can
