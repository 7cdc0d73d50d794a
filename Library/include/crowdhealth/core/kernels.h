// CrowdHealth — 2D SPH kernels with smoothing length h (Müller, Charypar & Gross 2003, the 2D
// normalisations used by van Toll et al. 2021). All are zero for r >= h.
#pragma once

#include "crowdhealth/core/types.h"

namespace ch::kernels {

/// Poly6: W(r) = 4/(π h⁸) (h² − r²)³, integrates to 1 over the disc of radius h. Takes r².
inline double poly6(double r2, double h) {
    const double h2 = h * h;
    if (r2 >= h2) return 0.0;
    const double d = h2 - r2;
    const double h8 = h2 * h2 * h2 * h2;
    return 4.0 / (kPi * h8) * d * d * d;
}

/// Magnitude of the spiky kernel's gradient: 30/(π h⁵) (h − r)². Its direction is −r̂ (towards
/// the neighbour means decreasing r). Takes r.
inline double spikyGradMagnitude(double r, double h) {
    if (r >= h) return 0.0;
    const double h5 = h * h * h * h * h;
    return 30.0 / (kPi * h5) * (h - r) * (h - r);
}

/// Viscosity kernel Laplacian: 360/(29 π h⁵) (h − r). Takes r.
inline double viscosityLaplacian(double r, double h) {
    if (r >= h) return 0.0;
    const double h5 = h * h * h * h * h;
    return 360.0 / (29.0 * kPi * h5) * (h - r);
}

}  // namespace ch::kernels
