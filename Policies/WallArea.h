// CrowdHealth — WallArea: how much of an SPH kernel disc lies behind wall segments, with
// occlusion (van Toll et al. 2021's analytic walls as DESIGN §4 describes them).
#pragma once

#include "crowdhealth/core/geometry.h"

#include <vector>

namespace ch::wallarea {

/// The part of a kernel disc that one wall segment hides from the disc's centre.
struct WallPiece {
    int segment = -1;   ///< index into the segment list
    double area = 0;    ///< m², area of the disc behind this segment (first hit only)
    Vec2 nearest{0, 0}; ///< nearest point of the segment to the centre (m)
    double distance = 0;  ///< |centre − nearest| (m)
};

/// For the disc of radius h around p and the segments `near` (indices into `segments`): for every
/// direction θ from p, the ray is followed to the FIRST segment it hits at t(θ) < h, and the
/// stretch of the ray from t(θ) to h is credited to that segment. Summed over θ this gives, per
/// segment, the area ∫ (h² − t(θ)²)/2 dθ of the disc hidden behind it. Back faces of thick walls
/// and walls behind other walls get nothing. Exact (piecewise closed form, no sampling):
/// on an angular interval where the first hit is the line at distance d with foot direction φ,
/// ∫ (h² − d²/cos²(θ−φ))/2 dθ = (h²/2)Δθ − (d²/2)[tan(θ−φ)].
/// Segments with no visible part inside the disc are not listed. `out` is cleared first.
void occludedAreas(const Vec2& p, double h, const std::vector<Segment>& segments, const std::vector<int>& near,
                   std::vector<WallPiece>& out);

}  // namespace ch::wallarea
