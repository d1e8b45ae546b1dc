// Edits of the vehicle configuration's text by `ndsid diagnose --apply`: one key at a time,
// everything else (comments, layout) kept, the result re-parsed to check the edit.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ndsid/config/config.h"

namespace ndsid::desk {

// The YAML text with `model: effects:` set to `effects`; adds the model section when missing.
// Throws ConfigError when the result does not parse to that list. `description` says what changed.
std::string SetModelEffects(const std::string& yaml_text, const std::vector<std::string>& effects,
                            const std::string& path_for_messages, std::string* description);

// The same for another list of names under `model:` (key "effects" or "alternatives"); a model
// section written on one line is rewritten for "effects" only (else a ConfigError).
std::string SetModelList(const std::string& yaml_text, const std::string& key, const std::vector<std::string>& names,
                         const std::string& path_for_messages, std::string* description);

// The YAML text with `signals.<role>.latency_s` set for each role given (flow `{...}` or block
// mapping). Throws ConfigError when a role is not configured or the result does not parse back
// to those values.
std::string SetRoleLatencies(const std::string& yaml_text, const std::map<config::Role, double>& latency_s,
                             const std::string& path_for_messages, std::string* description);

}  // namespace ndsid::desk
