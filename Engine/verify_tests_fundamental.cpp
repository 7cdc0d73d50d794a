// crowdhealth verify — RiMEA 4 and 16 (fundamental diagrams), validation against Weidmann and the
// SFPE/IMO hydraulic table. Not built yet: these rows are "pending" in the report.
#include "verify_suite.h"

namespace chverify {

void addFundamentalTests(std::vector<TestDef>&) {}

}  // namespace chverify
