#include "ndsid/common/closest_match.h"

#include <algorithm>
#include <cctype>

namespace ndsid {
namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

size_t EditDistance(const std::string& a_in, const std::string& b_in) {
  const std::string a = Lower(a_in), b = Lower(b_in);
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string ClosestMatch(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = SIZE_MAX;
  const std::string lw = Lower(word);
  for (const std::string& c : candidates) {
    const size_t limit = std::clamp<size_t>(std::max(word.size(), c.size()) / 3, 1, 3);
    const std::string lc = Lower(c);
    const bool contains = !lw.empty() && !lc.empty() && (lc.find(lw) != std::string::npos || lw.find(lc) != std::string::npos);
    // The distance is at least the difference in length, and exactly that when one word contains
    // the other (delete the rest). So a long hostile word (a fuzzed 8 kB key) costs one substring
    // search per candidate, not a |word| x |candidate| table: the table is filled only when the
    // candidate can be within the limit.
    const size_t length_gap = word.size() > c.size() ? word.size() - c.size() : c.size() - word.size();
    size_t d;
    if (contains) {
      d = length_gap;
    } else if (length_gap > limit) {
      continue;
    } else {
      d = EditDistance(word, c);
    }
    if ((d <= limit || contains) && d < best_distance) best = c, best_distance = d;
  }
  return best;
}

std::string AcceptedValuesHint(const std::string& word, const std::vector<std::string>& candidates) {
  std::string out;
  const std::string best = ClosestMatch(word, candidates);
  if (!best.empty()) out += "; did you mean '" + best + "'?";
  if (candidates.empty()) return out;
  out += " (accepted: ";
  for (size_t i = 0; i < candidates.size(); ++i) out += (i ? ", " : "") + candidates[i];
  return out + ")";
}

}  // namespace ndsid
