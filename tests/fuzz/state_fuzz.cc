// Fuzz target: the daemon's learned-state loader, DecodeState then RestoreState into a pipeline
// of the example vehicle, as StateStore::Load and the daemon's start do. First byte % 4 == 1: the
// rest is a format 2 payload (CBOR) and the harness writes a valid header with its checksum, so
// the document readers are reached; == 3: the same with a format 1 header (the migration of the
// old sections, docs/state-format.md); even: the rest is the whole file. Only StateFileError /
// ndsid::Error may come out, and no input may exhaust the stack or the memory.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "ndsid/config/config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/pipeline/pipeline.h"
#include "state_store.h"

namespace {

struct Fixture {
  ndsid::config::Config config = ndsid::config::LoadConfig(NDSID_SOURCE_DIR "/config/example_vehicle.yaml");
  ndsid::dbc::Database db = ndsid::dbc::ParseDbcFile(config.dbc);
  ndsid::pipeline::Pipeline pipeline{config, db};
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Fixture* f = new Fixture();
  if (size < 1) return 0;
  std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  const std::string& vehicle = f->config.vehicle.name;
  if (data[0] % 2 == 1) {
    const int version = data[0] % 4 == 3 ? 1 : ndsid::service::kStateFormatVersion;
    char checksum[17];
    std::snprintf(checksum, sizeof checksum, "%016llx",
                  static_cast<unsigned long long>(ndsid::service::Fnv1a64(bytes)));
    bytes = "NDSID-STATE " + std::to_string(version) + "\nvehicle " + vehicle +
            "\npayload_bytes " + std::to_string(bytes.size()) + "\npayload_fnv1a64 " + checksum + "\n\n" + bytes;
  }
  try {
    const ndsid::service::LearnedState st = ndsid::service::DecodeState(bytes, vehicle);
    std::string dropped;
    ndsid::service::RestoreState(f->pipeline, f->config, st, dropped);
  } catch (const ndsid::Error&) {
  }
  return 0;
}
