#include "ndsid/identify/model_output.h"

#include "chunk_cost.h"

namespace ndsid::identify {

std::vector<ChunkOutput> SimulateChunks(const Identifier& identifier, const std::vector<double>& params,
                                        const SegmentList& segments) {
  const auto& cfg = identifier.config();
  std::vector<ChunkOutput> out;
  for (size_t i = 0; i < segments.size(); ++i) {
    const stats::Segment* seg = segments[i];
    for (const Chunk& c : MakeChunks({seg}, cfg.chunk_s, cfg.burn_in_s, identifier.drive_overrides())) {
      ChunkOutput o;
      o.segment = seg;
      o.segment_index = i;
      o.first = static_cast<size_t>(c.samples - seg->samples.data());
      o.n = c.n;
      o.burn_in = BurnInSamples(c, cfg.burn_in_s);
      o.a_y_model_mps2.resize(c.n);
      model::SimulationTrace trace;
      model::SimulateModel(identifier.spec(), c.ParamsFor(params).data(), identifier.wheelbase_m(), c.Inputs(),
                           o.a_y_model_mps2.data(), &trace);
      o.yaw_rate_model_radps = std::move(trace.yaw_rate_meas_radps);  // r + gyro effects: comparable to r_meas
      out.push_back(std::move(o));
    }
  }
  return out;
}

}  // namespace ndsid::identify
