// CrowdHealth — PLEdestrians (Guy et al. 2010), see PLEdestrians.h.
#include "PLEdestrians.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(PLEdestrians);

ComponentInfo PLEdestrians::Info() {
    ComponentInfo info;
    info.name = "PLEdestrians";
    info.kind = ComponentKind::CostFunction;
    info.summary = "least biomechanical effort to the goal over a horizon, collisions before t_min forbidden";
    info.reference =
        "Guy, Chhugani, Curtis, Dubey, Lin & Manocha 2010, PLEdestrians: a least-effort approach to crowd "
        "simulation, SCA 2010, pp. 119-128";
    ParamSpec wa = ParamSpec::real("w_a", "J/(kg*s)", 2.23, 0.0, 1e3, "e_s: metabolic power spent per unit mass at rest");
    wa.minExclusive = true;
    ParamSpec wb = ParamSpec::real("w_b", "J*s/(kg*m2)", 1.26, 0.0, 1e3, "e_w: extra power per unit mass per (m/s)^2");
    wb.minExclusive = true;
    ParamSpec tMax = ParamSpec::real("t_max", "s", 3.0, 0.0, 1e3, "planning horizon over which a candidate velocity is followed");
    tMax.minExclusive = true;
    info.params = {
        wa,
        wb,
        ParamSpec::real("t_min", "s", 0.5, 0.0, 1e3, "velocities that collide sooner than this are not allowed"),
        tMax,
        ParamSpec::choice("overlap", {"ignore", "closing"}, 0,
                          "a neighbour or wall the agent already overlaps: ignore = left out, contact forces "
                          "separate the pair (UMANS 1.x); closing = every velocity that closes the gap is "
                          "inadmissible"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<PLEdestrians>(p); };
    return info;
}

PLEdestrians::PLEdestrians(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "w_a", wa_);
    bind(params, "w_b", wb_);
    bind(params, "t_min", tMin_);
    bind(params, "t_max", tMax_);
    bind(params, "overlap", overlap_);
}

double PLEdestrians::timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    return ch::timeToFirstCollision(v, q, ctx, range_, overlap_ == 0 ? OverlapRule::Ignore : OverlapRule::Closing);
}

Vec2 PLEdestrians::goalOffset(const AgentQuery& q, const StepContext& ctx) const {
    const AgentStore& A = ctx.agents;
    // With global navigation (or a journey) the goal lies along the path: the path's direction
    // times the distance left on it (crowdhealth/navigation/navigation.h).
    if (A.navigationColumns && A.target[q.i] >= 0 && A.navDistance[q.i] >= 0) return A.navDir[q.i] * A.navDistance[q.i];
    return A.hasGoal[q.i] ? Vec2(A.goal[q.i] - q.position) : Vec2(0, 0);
}

namespace {
/// Weight (J·s/(kg·m)) of the right-hand tie-break: far below any real difference of effort.
constexpr double kTieBreak = 1e-5;
/// Unit vector to the left of the preferred direction (zero at the goal).
Vec2 leftOf(const AgentQuery& q) {
    const Vec2 d = normalisedOrZero(q.prefVelocity);
    return {-d.y(), d.x()};
}
}  // namespace

double PLEdestrians::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    if (timeToFirstCollision(v, q, ctx) < tMin_) return kInf;
    const Vec2 rest = goalOffset(q, ctx) - tMax_ * v;  // still to walk after the horizon
    return tMax_ * (wa_ + wb_ * v.squaredNorm()) + 2.0 * std::sqrt(wa_ * wb_) * rest.norm() +
           kTieBreak * v.dot(leftOf(q));
}

Vec2 PLEdestrians::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    if (timeToFirstCollision(v, q, ctx) < tMin_) return {0, 0};
    const Vec2 rest = goalOffset(q, ctx) - tMax_ * v;
    Vec2 g = 2.0 * tMax_ * wb_ * v + kTieBreak * leftOf(q);
    const double len = rest.norm();
    if (len > 1e-12) g -= 2.0 * std::sqrt(wa_ * wb_) * tMax_ * rest / len;
    return g;
}

std::optional<Vec2> PLEdestrians::globalMinimum(const AgentQuery& q, const StepContext& ctx) const {
    const Vec2 toGoal = goalOffset(q, ctx);
    const double uStar = std::sqrt(wa_ / wb_);
    const double dist = toGoal.norm();
    const Vec2 best = dist > uStar * tMax_ ? Vec2(toGoal * (uStar / dist)) : Vec2(toGoal / tMax_);
    if (timeToFirstCollision(best, q, ctx) < tMin_) return std::nullopt;  // constrained: sample
    return best;
}

}  // namespace ch
