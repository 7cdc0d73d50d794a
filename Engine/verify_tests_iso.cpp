// crowdhealth verify — ISO 20414 / NIST TN 1822: corridor speed, premovement distributions
// (Kolmogorov-Smirnov), demographics, counter-flow, groups. Not built yet: these rows are
// "pending" in the report.
#include "verify_suite.h"

namespace chverify {

void addIsoTests(std::vector<TestDef>&) {}

}  // namespace chverify
