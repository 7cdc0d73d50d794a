// CrowdHealth — SocialGroups: members of a social group walk together (Moussaïd et al. 2010).
#pragma once

#include "crowdhealth/core/registry.h"

#include <vector>

namespace ch {

/// The group term of M. Moussaïd, N. Perozo, S. Garnier, D. Helbing, G. Theraulaz (2010), "The
/// walking behaviour of pedestrian social groups and its impact on crowd dynamics", PLoS ONE 5(4):
/// e10047, eq. 3–6, as an acceleration added to any policy's own (a force component):
///
///   a_group = a_gaze + a_coherence + a_repulsion
///   a_gaze       = −β1 α_i v_i          α_i: how far (rad) the head must turn beyond the half field
///                                       of view φ to see the centre of mass of the other members
///                                       while facing the walking direction; 0 when it is in view
///   a_coherence  = q_A β2 û_i           û_i: unit vector to the group's centre of mass; q_A = 1 when
///                                       that centre is farther than spacing·(N − 1)
///   a_repulsion  = Σ_k q_R β3 ŵ_ik       ŵ_ik: unit vector from member k to i; q_R = 1 when i and k
///                                       are closer than r_i + r_k + personal_space
///
/// Paper values: β1 = 4, β2 = 3, β3 = 1, φ = 90°, the coherence threshold (N − 1)/2 m for N members
/// (our `spacing` = 0.5 m per member after the first); the paper's repulsion acts when members
/// overlap, our `personal_space` (default 0.1 m) keeps them a hand apart instead. The gaze term
/// slows a member who walks ahead of the others (its head would have to turn back) and the
/// coherence term pulls back one who strays: together they make a group wait for a slower member.
/// The centre of mass is that of the members present (those who left are no longer counted), on a
/// torus by minimum-image offsets from the agent. Groups come from Agent@group and
/// AgentGrid@group_size (docs/crowd-health.md, "Groups"); agents without a group get nothing.
/// Like the goal force it is a desire, not a body force: not divided by the mass.
class SocialGroups : public ForceComponent {
public:
    explicit SocialGroups(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only the query and the agents' store
    bool readsQueryAgents() const override { return false; }
    void prepare(const StepContext& ctx) override;
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const override;

private:
    double gaze_ = 4.0;           ///< β1, 1/s per rad
    double coherence_ = 3.0;      ///< β2, m/s²
    double repulsion_ = 1.0;      ///< β3, m/s²
    double spacing_ = 0.5;        ///< m per member after the first: coherence acts beyond spacing·(N−1)
    double fieldOfView_ = 90.0;   ///< φ, degrees either side of the walking direction
    double personalSpace_ = 0.1;  ///< m beyond touching within which members repel each other
    /// The present members of each group (indices into the step's AgentStore), filled by prepare().
    std::vector<std::vector<int>> members_;
};

}  // namespace ch
