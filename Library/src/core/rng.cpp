// CrowdHealth — random streams.
#include "crowdhealth/core/rng.h"

#include "crowdhealth/core/types.h"

#include <cmath>

namespace ch {

double Rng::normal() {
    // Box–Muller; 1 - u keeps the logarithm's argument in (0, 1].
    const double u1 = 1.0 - uniform();
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

}  // namespace ch
