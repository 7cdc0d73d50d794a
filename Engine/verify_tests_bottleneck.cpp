// crowdhealth verify — RiMEA 12 (effect of bottlenecks, a-d) and validation of the bottleneck flow
// against Kretz et al. 2006. Not built yet: these rows are "pending" in the report.
#include "verify_suite.h"

namespace chverify {

void addBottleneckTests(std::vector<TestDef>&) {}

}  // namespace chverify
