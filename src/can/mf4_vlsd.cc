#include "mf4_vlsd.h"

#include <algorithm>

#include "ndsid/can/can_frame.h"

namespace ndsid::can::detail {

const char* Mf4SignalData::Read(uint64_t offset, Mf4VlsdValue& out) noexcept {
  try {
    if (stream_ == nullptr || offset < stream_->position()) stream_ = std::make_unique<Mf4DataStream>(file_, link_);
  } catch (...) {
    return "out of memory";
  }
  if (!stream_->SkipBytes(offset - stream_->position())) return "DataBytes offset beyond its signal data";
  uint8_t head[4];
  if (!stream_->Read(head, sizeof head)) return "DataBytes offset beyond its signal data";
  out.length = head[0] | head[1] << 8 | head[2] << 16 | static_cast<uint32_t>(head[3]) << 24;
  if (out.length > kMaxVlsdBytes) return "DataBytes value longer than 1 MiB (corrupt signal data)";
  const uint32_t keep = std::min<uint32_t>(out.length, kMaxPayload);
  out.bytes.resize(keep);
  if (!stream_->Read(out.bytes.data(), keep) || !stream_->SkipBytes(out.length - keep)) {
    return "DataBytes value cut at the end of its signal data";
  }
  return nullptr;
}

uint64_t Mf4VlsdGroup::NextValueKey(uint32_t length) noexcept {
  const uint64_t key = by_order_ ? values_ : next_offset_;
  ++values_;
  next_offset_ += 4 + uint64_t{length};
  return key;
}

void Mf4VlsdGroup::Keep(uint64_t key, Mf4VlsdValue value) noexcept {
  try {
    if (unclaimed_.size() >= kMaxUnclaimed) unclaimed_.pop_front();
    unclaimed_.emplace_back(key, std::move(value));
  } catch (...) {
  }
}

bool Mf4VlsdGroup::Take(uint64_t key, Mf4VlsdValue& out) noexcept {
  for (auto it = unclaimed_.begin(); it != unclaimed_.end(); ++it) {
    if (it->first == key) {
      out = std::move(it->second);
      unclaimed_.erase(it);
      return true;
    }
  }
  return false;
}

}  // namespace ndsid::can::detail
