// CrowdHealth — the SIMD helpers of SocialForcesAvoidance's pair loop (issue 20): four doubles per
// value and their exponential, simd::expNonPositive. They live in the library
// (crowdhealth/core/simd.h) since the crowd field's Gaussian weights use the exponential too.
#pragma once

#include "crowdhealth/core/simd.h"

// The pair loop and its test pass simd::DV by value between inlined helpers: no call crosses an ABI.
#pragma GCC diagnostic ignored "-Wpsabi"
