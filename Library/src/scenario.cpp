// CrowdHealth — ScenarioSpec helpers.
#include "crowdhealth/scenario.h"

#include <algorithm>
#include <cmath>

namespace ch {

int ScenarioSpec::fineStepsPerCoarse() const {
    // The loader guarantees deltaTime = n · deltaTimeFine (relative tolerance 1e-9); rounding
    // absorbs the representation error of decimal inputs such as 0.1 / 0.02.
    if (deltaTimeFine <= 0 || deltaTime <= 0) return 1;
    return std::max(1, static_cast<int>(std::lround(deltaTime / deltaTimeFine)));
}

}  // namespace ch
