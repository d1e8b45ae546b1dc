// "Did you mean": the accepted word closest to a mistyped one, for error messages that list the
// accepted values (unknown config keys, units, effect names).
#pragma once

#include <string>
#include <vector>

namespace ndsid {

// Edit distance (insertions, deletions, substitutions; case-insensitive).
size_t EditDistance(const std::string& a, const std::string& b);

// The candidate closest to `word`, or "" when none is close: within an edit distance of a third
// of the longer word (at least 1, at most 3), or when one contains the other case-insensitively.
std::string ClosestMatch(const std::string& word, const std::vector<std::string>& candidates);

// "; did you mean 'x'? (accepted: a, b, c)" — or only the accepted list when nothing is close.
std::string AcceptedValuesHint(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace ndsid
