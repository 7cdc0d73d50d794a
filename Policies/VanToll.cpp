// CrowdHealth — VanToll (van Toll & Pettré 2019).
#include "VanToll.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(VanToll);

ComponentInfo VanToll::Info() {
    ComponentInfo info;
    info.name = "VanToll";
    info.kind = ComponentKind::CostFunction;
    info.summary = "distance to the first collision plus deviations from the preferred and current motion "
                   "(includes goal reaching; use with sampling)";
    info.reference = "van Toll & Pettre 2019, Connecting global and local agent navigation via topology, MIG 2019";
    info.params = {ParamSpec::real("max_distance", "m", 8.0, 0.0, 1e4,
                                   "distance to collision beyond which a velocity is considered safe")};
    info.params.back().minExclusive = true;
    info.create = [](const ParamSet& p) { return std::make_unique<VanToll>(p); };
    return info;
}

VanToll::VanToll(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "max_distance", maxDistance_);
}

namespace {
/// Unsigned angle between two vectors in [0, π]; 0 when either is zero (as UMANS).
double angleBetween(const Vec2& a, const Vec2& b) {
    if (a.squaredNorm() == 0 || b.squaredNorm() == 0) return 0.0;
    const double cross = a.x() * b.y() - a.y() * b.x();
    return std::atan2(std::abs(cross), a.dot(b));
}
}  // namespace

double VanToll::timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    return ch::timeToFirstCollision(v, q, ctx, range_);
}

double VanToll::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const double s = v.norm();
    const double ps = q.prefVelocity.norm();

    const double ttc = timeToFirstCollision(v, q, ctx);
    const double distanceToCollision = std::isfinite(ttc) ? std::min(ttc * s, maxDistance_) : maxDistance_;

    const double collisionTerm = maxDistance_ - distanceToCollision;
    const double preferredAngle = angleBetween(v, q.prefVelocity);
    // At the goal (no preferred velocity) the speed term becomes the absolute speed.
    const double speedTerm = ps > 1e-9 ? std::abs(s - ps) / ps : s;
    const double currentAngle = angleBetween(v, q.velocity);
    return collisionTerm + preferredAngle + speedTerm + currentAngle;
}

}  // namespace ch
