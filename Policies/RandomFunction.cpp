// CrowdHealth — RandomFunction.
#include "RandomFunction.h"

#include <cstdint>
#include <cstring>

namespace ch {

CH_REGISTER_COMPONENT(RandomFunction);

ComponentInfo RandomFunction::Info() {
    ComponentInfo info;
    info.name = "RandomFunction";
    info.kind = ComponentKind::CostFunction;
    info.summary = "random cost in [-1, 1] and random gradient in [-1, 1]^2: noise on navigation (avoids nothing)";
    info.reference = "UMANS test cost function (van Toll et al. 2020, Generalized microscopic crowd simulation "
                     "using costs in velocity space, I3D)";
    info.params = {};
    info.create = [](const ParamSet& p) { return std::make_unique<RandomFunction>(p); };
    return info;
}

RandomFunction::RandomFunction(const ParamSet& params) { bind(params, "range", range_); }

namespace {
std::uint64_t bitsOf(double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
}
double unitFromBits(std::uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }
}  // namespace

double RandomFunction::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    Rng rng = ctx.rng(q, kStreamCostFunction);
    // The stream's first number keys this (agent, step); the candidate's bits select the value.
    const std::uint64_t key = rng.nextU64();
    const std::uint64_t h = mix64(key ^ mix64(bitsOf(v.x()) ^ mix64(bitsOf(v.y()))));
    return -1.0 + 2.0 * unitFromBits(h);
}

Vec2 RandomFunction::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    (void)v;
    Rng rng = ctx.rng(q, kStreamCostFunction);
    rng.nextU64();  // the cost's key
    const double gx = rng.uniform(-1.0, 1.0);
    const double gy = rng.uniform(-1.0, 1.0);
    return {gx, gy};
}

}  // namespace ch
