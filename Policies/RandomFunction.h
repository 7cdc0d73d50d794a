// CrowdHealth — RandomFunction: random costs and gradients (noise for tests and experiments).
#pragma once

#include "crowdhealth/core/registry.h"

namespace ch {

/// UMANS' test cost function `RandomFunction` (no paper): the cost of any velocity is uniform in
/// [−1, 1] and the gradient is uniform in [−1, 1]², so adding it with a small `coeff` puts noise
/// on an agent's navigation. It does not avoid anything.
///
/// Reproducibility (unlike UMANS, which draws from a per-agent generator in call order): every
/// value is a pure function of (run seed, agent id, step, stream kStreamCostFunction) and, for the
/// cost, of the candidate velocity's bits. So two candidates get independent costs, the same
/// candidate evaluated twice gets the same cost, and results do not depend on thread count or on
/// how often the optimiser calls the function. Two RandomFunction entries in one policy draw the
/// same numbers (scale one `coeff` instead).
/// UMANS gives it range 0; here the common `range` default applies, but the function reads no
/// neighbour, so it only widens the neighbourhood gathered for the step.
class RandomFunction : public Component {
public:
    explicit RandomFunction(const ParamSet& params);
    static ComponentInfo Info();
    bool readsStepLists() const override { return false; }  ///< only the query
    bool readsQueryAgents() const override { return false; }
    double cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
    Vec2 gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const override;
};

}  // namespace ch
