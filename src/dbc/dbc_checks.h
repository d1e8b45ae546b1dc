// Checks run on a parsed database: multiplexing consistency, signals that do not fit their
// message, overlapping signals. Each finding becomes a Warning (the file still loads). Private.
#pragma once

#include "ndsid/dbc/database.h"

namespace ndsid::dbc::internal {

// Demotes inconsistent multiplexing (several `M`, or `mN` without `M`) to plain signals as
// cantools does, and warns about it, about signals beyond the message length and about
// signals sharing bits (when both can be present in the same frame).
void CheckMessages(Database& db);

}  // namespace ndsid::dbc::internal
