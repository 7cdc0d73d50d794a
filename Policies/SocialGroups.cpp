// CrowdHealth — SocialGroups (Moussaïd et al. 2010); the equations are in SocialGroups.h.
#include "SocialGroups.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace ch {

CH_REGISTER_COMPONENT(SocialGroups);

ComponentInfo SocialGroups::Info() {
    ComponentInfo info;
    info.name = "SocialGroups";
    info.kind = ComponentKind::Force;
    info.defaultRange = 0.0;  // members are found through their group, not among neighbours
    info.summary = "members of a social group (Agent@group) keep together: gaze, coherence and repulsion terms";
    info.reference = "Moussaid, Perozo, Garnier, Helbing & Theraulaz 2010, PLoS ONE 5(4):e10047, eq. 3-6";
    info.params = {
        ParamSpec::real("gaze", "1/s", 4.0, 0.0, 100.0, "beta1: slows a member whose group is out of its field of view"),
        ParamSpec::real("coherence", "m/s2", 3.0, 0.0, 100.0, "beta2: pulls a member back towards the group's centre"),
        ParamSpec::real("repulsion", "m/s2", 1.0, 0.0, 100.0, "beta3: pushes members apart when too close"),
        ParamSpec::real("spacing", "m", 0.5, 0.0, 10.0, "coherence acts beyond spacing x (members - 1) from the centre"),
        ParamSpec::real("field_of_view", "deg", 90.0, 0.0, 180.0, "half-angle of the field of view"),
        ParamSpec::real("personal_space", "m", 0.1, 0.0, 5.0, "members closer than r_i + r_k + this repel"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<SocialGroups>(p); };
    return info;
}

SocialGroups::SocialGroups(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "gaze", gaze_);
    bind(params, "coherence", coherence_);
    bind(params, "repulsion", repulsion_);
    bind(params, "spacing", spacing_);
    bind(params, "field_of_view", fieldOfView_);
    bind(params, "personal_space", personalSpace_);
}

void SocialGroups::prepare(const StepContext& ctx) {
    for (std::vector<int>& m : members_) m.clear();
    const std::vector<int>& group = ctx.agents.group;
    for (std::size_t i = 0; i < group.size(); ++i) {
        const int g = group[i];
        if (g < 0) continue;
        if (static_cast<std::size_t>(g) >= members_.size()) members_.resize(static_cast<std::size_t>(g) + 1);
        members_[static_cast<std::size_t>(g)].push_back(static_cast<int>(i));
    }
}

Vec2 SocialGroups::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    const int g = ctx.agents.group[static_cast<std::size_t>(q.i)];
    if (g < 0 || static_cast<std::size_t>(g) >= members_.size()) return Vec2(0, 0);
    const std::vector<int>& members = members_[static_cast<std::size_t>(g)];
    const std::size_t n = members.size();
    if (n < 2) return Vec2(0, 0);

    // Offsets from i to every other member (minimum image on a torus), their mean, and repulsion.
    Vec2 sumOthers(0, 0), a(0, 0);
    for (int k : members) {
        if (k == q.i) continue;
        const Vec2 d = ctx.world.offset(q.position, ctx.agents.pos[static_cast<std::size_t>(k)]);
        sumOthers += d;
        const double dist = d.norm();
        const double near = q.radius + ctx.agents.radius[static_cast<std::size_t>(k)] + personalSpace_;
        if (dist < near && dist > 1e-12) a -= repulsion_ * d / dist;
    }
    const Vec2 toOthers = sumOthers / static_cast<double>(n - 1);  // centre of the other members
    const Vec2 toCentre = sumOthers / static_cast<double>(n);      // centre of the whole group (i at 0)

    // Coherence: beyond spacing·(N − 1) from the group's centre.
    const double dc = toCentre.norm();
    if (dc > spacing_ * static_cast<double>(n - 1) && dc > 1e-12) a += coherence_ * toCentre / dc;

    // Gaze: the head faces the walking direction; turning it further than the field of view to see
    // the others costs speed.
    const double speed = q.velocity.norm();
    const double dOthers = toOthers.norm();
    if (speed > 1e-9 && dOthers > 1e-12) {
        const double cosine = std::clamp(q.velocity.dot(toOthers) / (speed * dOthers), -1.0, 1.0);
        const double alpha = std::acos(cosine) - fieldOfView_ * std::numbers::pi / 180.0;
        if (alpha > 0) a -= gaze_ * alpha * q.velocity;
    }
    return a;
}

}  // namespace ch
