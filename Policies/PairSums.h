// CrowdHealth — the dense crowd's per-agent pair sums over a neighbour list, each with a scalar
// build and an AVX-512 build (issue 20): SPH's density, SPH's pressure and viscosity (a fifth of
// the dense step, bound by a square root and three divisions per pair) and ContactForces' agent
// springs.
//
// Both builds give the same bits: each pair's term is the same expression with the same roundings
// (IEEE square root and division, no fused multiply-add), and the terms are added one by one in
// list order. The AVX-512 build computes eight pairs' terms at a time, then adds them in order.
#pragma once

#include "crowdhealth/core/component.h"
#include "crowdhealth/core/neighbours.h"
#include "crowdhealth/core/types.h"

#include <cstddef>
#include <vector>

namespace ch::pairs {

/// A stored neighbour list read by index (NeighbourLists::indices, plane worlds): entry k's agent
/// is indices[k] and its offset positions[indices[k]] − origin, computed on reading (the offset the
/// list's gather saw, to the bit: NeighbourLists::offset). When `indices` is set, a sum reads it
/// instead of `entries`.
struct IndexList {
    const int* indices = nullptr;
    const Vec2* positions = nullptr;
    Vec2 origin{0, 0};  ///< positions[i]
};

/// What SPH's pair sum reads: agent i's list and state, the neighbours' columns, the kernels'
/// constants (SPH.cpp's SphKernels: spiky gradient cS (h − r)², viscosity Laplacian cV (h − r)).
struct SphInput {
    const NeighbourAgent* entries = nullptr;  ///< agent i's neighbour list
    IndexList byIndex;                        ///< or the stored list by index (then entries is unread)
    std::size_t count = 0;
    const double* mass = nullptr;      ///< m_j, by agent index
    const double* density = nullptr;   ///< ρ_j
    const double* pressure = nullptr;  ///< p_j
    const Vec2* velocity = nullptr;    ///< v_j
    double h = 1, h2 = 1, cS = 0, cV = 0;
    double pressureI = 0;  ///< p_i
    bool pushes = false;   ///< p_i > 0: the pressure term counts (absolute pressure)
    double viscosity = 0;  ///< μ; the viscosity term counts when > 0
    Vec2 velocityI{0, 0};  ///< v_i
};

/// Σ_j over the entries with r = |offset| < h, r ≥ 1e-12 and ρ_j > 0, in list order, of
///   m_j (p_i + p_j) / (2 ρ_j) · cS (h − r)² · (−offset / r)       (when `pushes`)
///   μ m_j / ρ_j · cV (h − r) · (v_j − v_i)                         (when μ > 0)
/// (not yet divided by ρ_i).
Vec2 sphForce(const SphInput& in);

/// What SPH's density sum reads.
struct DensityInput {
    const NeighbourAgent* entries = nullptr;  ///< agent i's neighbour list
    IndexList byIndex;                        ///< or the stored list by index (then entries is unread)
    std::size_t count = 0;
    const double* mass = nullptr;  ///< m_j, by agent index
    double h2 = 1, c6 = 0;         ///< poly6 kernel: c6 (h² − r²)³ for r² < h²
    double start = 0;              ///< the sum so far: agent i's own term m_i W(0)
};

/// start + Σ_j over the entries with |offset|² < h², in list order, of m_j c6 (h² − |offset|²)³.
double sphDensity(const DensityInput& in);

/// What ContactForces' agent springs read.
struct ContactInput {
    const NeighbourAgent* entries = nullptr;  ///< agent i's neighbour list
    IndexList byIndex;                        ///< or the stored list by index (then entries is unread)
    std::size_t count = 0;
    const double* radius = nullptr;  ///< D_j, by agent index
    double radiusI = 0;              ///< D_i
    double reach2 = 0;               ///< entries farther than √reach2 are not looked at: (D_i + max D)²
    double stiffness = 0;            ///< K_ag
};

/// Σ_j over the entries with |offset|² ≤ reach2, |offset|² < (D_i + D_j)², overlap
/// D_i + D_j − r > 0 and r > 1e-12, in list order, of K_ag · overlap · (−offset / r)
/// (not yet divided by the mass).
Vec2 contactForce(const ContactInput& in);

/// Points a sum's input (SphInput, DensityInput, ContactInput) at agent i's list of the agents within
/// `radius`: the step's stored list by index where it reaches that far in a plane world (no copy:
/// the sum computes the offsets), else StepContext::neighbourList's entries in `scratch`. Either
/// way the sum sees the same entries, offsets and order.
template <class Input>
void setList(Input& in, const StepContext& ctx, std::size_t i, double radius, std::vector<NeighbourAgent>& scratch) {
    if (ctx.listReaches(i, radius) && ctx.lists->plane()) {
        const std::span<const int> list = ctx.lists->indices(i);
        in.entries = nullptr;
        in.byIndex = IndexList{list.data(), ctx.lists->positions().data(), ctx.lists->positions()[i]};
        in.count = list.size();
        return;
    }
    const std::span<const NeighbourAgent> list = ctx.neighbourList(i, radius, scratch);
    in.entries = list.data();
    in.byIndex = IndexList{};
    in.count = list.size();
}

/// The builds: 0 scalar (every CPU), 1 AVX-512 (F, DQ, VL). The best this CPU runs is used;
/// setPath returns false and changes nothing when this CPU cannot run `path` (tests and the
/// benchmark compare them).
int path();
bool setPath(int path);

}  // namespace ch::pairs
