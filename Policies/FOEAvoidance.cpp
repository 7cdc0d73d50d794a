// CrowdHealth — FOEAvoidance (López, Chaumette, Marchand & Pettré 2019).
#include "FOEAvoidance.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(FOEAvoidance);

ComponentInfo FOEAvoidance::Info() {
    ComponentInfo info;
    info.name = "FOEAvoidance";
    info.kind = ComponentKind::CostFunction;
    info.summary = "avoidance from the distance between each neighbour's image and its focus of expansion "
                   "(analytic gradient; pair with GoalReachingForce)";
    info.reference = "Lopez, Chaumette, Marchand & Pettre 2019, Character navigation in dynamic environments "
                     "based on optical flow, Computer Graphics Forum 38(2):181";
    info.params = {
        ParamSpec::real("importance_max", "-", 10.0, 0.0, 1e6, "importance I0 of a crossing happening now"),
        ParamSpec::real("importance_time", "s", 5.0, 0.0, 1e3,
                        "time t0 at which the linearly decreasing importance would reach 0"),
        ParamSpec::real("importance_min", "-", 0.1, 0.0, 1e6, "floor of the importance for crossings up to max_ttc"),
        ParamSpec::real("max_ttc", "s", 10.0, 0.0, 1e3, "crossings later than this are ignored"),
    };
    info.params[1].minExclusive = true;
    info.create = [](const ParamSet& p) { return std::make_unique<FOEAvoidance>(p); };
    return info;
}

FOEAvoidance::FOEAvoidance(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "importance_max", importanceMax_);
    bind(params, "importance_time", importanceTime_);
    bind(params, "importance_min", importanceMin_);
    bind(params, "max_ttc", maxTtc_);
}

double FOEAvoidance::importance(double ttc, double* slope) const {
    *slope = 0.0;
    if (ttc < 0.0 || ttc > maxTtc_) return 0.0;
    const double k = importanceMax_ / importanceTime_;
    const double linear = importanceMax_ - k * ttc;
    if (linear <= importanceMin_) return importanceMin_;
    if (linear >= importanceMax_) return importanceMax_;
    *slope = -k;
    return linear;
}

double FOEAvoidance::pairCost(const Vec2& v, const Vec2& P, const Vec2& u, double R, Vec2* grad) const {
    const double s = v.norm();
    if (s == 0.0) return 0.0;
    const Vec2 f = v / s;              // depth axis
    const Vec2 e(f.y(), -f.x());       // image axis (to the right)
    const Vec2 V = u - v;              // neighbour's velocity relative to the agent
    const double Y = P.dot(f);         // depth of the neighbour
    const double Vy = V.dot(f);        // its depth rate
    if (Y < 0.1 || Vy > -0.01) return 0.0;

    const double D = -Vy;                             // closing speed in depth (> 0)
    const double N = P.x() * V.y() - P.y() * V.x();   // P × V: lateral miss distance · D
    const double ttc = Y / D;
    double slope;
    const double I = importance(ttc, &slope);
    if (I == 0.0) return 0.0;
    const double miss = std::abs(N) / D;
    const double k = std::log(10.0) / R;
    const double E = std::exp(-k * miss);
    const double c = I * E;

    if (grad != nullptr) {
        const double X = P.dot(e);
        const Vec2 gY = X * e / s;                      // ∇(P·f)
        const Vec2 gVy = u.dot(e) * e / s - f;          // ∇(V·f) = ∇(u·f) − ∇|v|
        const Vec2 gD = -gVy;
        const Vec2 gN(P.y(), -P.x());                   // ∇(P × (u − v))
        const double sign = N >= 0 ? 1.0 : -1.0;        // sign(0) := +1: leave towards the right
        const Vec2 gMiss = sign * gN / D - std::abs(N) * gD / (D * D);
        const Vec2 gTtc = gY / D - Y * gD / (D * D);
        *grad += slope * E * gTtc - I * E * k * gMiss;
    }
    return c;
}

double FOEAvoidance::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    double sum = 0;
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        sum += pairCost(v, n.offset, ctx.agents.vel[n.index], q.radius + ctx.agents.radius[n.index], nullptr);
    }
    return sum;
}

Vec2 FOEAvoidance::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    Vec2 g(0, 0);
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        pairCost(v, n.offset, ctx.agents.vel[n.index], q.radius + ctx.agents.radius[n.index], &g);
    }
    return g;
}

}  // namespace ch
