// CrowdHealth — ContactForces, see ContactForces.h.
#include "ContactForces.h"

#include "PairSums.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(ContactForces);

ComponentInfo ContactForces::Info() {
    ComponentInfo info;
    info.name = "ContactForces";
    info.kind = ComponentKind::Force;
    info.defaultRange = 0.0;
    info.modelsContact = true;
    info.summary = "linear contact springs between overlapping agents and between agents and walls (inside the a_max clamp); its policy gets no implicit UMANS ContactForceScale";
    info.reference = "van Toll et al. 2021, SPH crowds, Computers & Graphics 98 (contact forces); CrowdHealth paper eq. 1";
    info.params = {
        ParamSpec::real("agentStiffness", "1/s2", 50.0, 0.0, 1e7, "K_ag: acceleration per metre of overlap between two agents"),
        ParamSpec::real("obstacleStiffness", "1/s2", 200.0, 0.0, 1e7, "K_obs: acceleration per metre of overlap with a wall"),
        ParamSpec::choice("wallRule", {"vantoll", "prototype"}, 0,
                          "vantoll: every wall segment within the radius; prototype: one wall per obstacle, adjacent "
                          "wall first, largest penetration, push out when the centre is inside"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<ContactForces>(p); };
    return info;
}

ContactForces::ContactForces(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "agentStiffness", agentStiffness_);
    bind(params, "obstacleStiffness", obstacleStiffness_);
    bind(params, "wallRule", wallRule_);
}

void ContactForces::remapAgents(const std::vector<int>& previous) {
    // Empty until the first step (prepare() assigns every agent's entry): readers of
    // contactField() check its size.
    remapColumn(accel_, previous, Vec2(0, 0), true);
}

namespace {

/// Outward unit normal of segment s (for a centre lying exactly on it): the polygon's
/// orientation tells which side is outside.
Vec2 outwardNormal(const Segment& s, const World& world) {
    const Vec2 ab = normalisedOrZero(s.b - s.a);
    Vec2 n(ab.y(), -ab.x());  // right-hand side: outside for a counter-clockwise polygon
    if (s.obstacle >= 0 && polygonArea(world.obstacles()[static_cast<std::size_t>(s.obstacle)].points) < 0) n = -n;
    return n;
}

}  // namespace

Vec2 ContactForces::wallsVanToll(std::size_t i, const StepContext& ctx, std::vector<int>& near) const {
    const Vec2& x = ctx.agents.pos[i];
    const double D = ctx.agents.radius[i];
    Vec2 a(0, 0);
    ctx.segmentsNear(i, D, near);
    for (int s : near) {
        const Segment& seg = ctx.world.segments()[static_cast<std::size_t>(s)];
        const Vec2 diff = x - closestPointOnSegment(x, seg.a, seg.b);
        const double d = diff.norm();
        if (d >= D) continue;
        const Vec2 dir = d > 1e-12 ? Vec2(diff / d) : outwardNormal(seg, ctx.world);
        a += obstacleStiffness_ * (D - d) * dir;
    }
    return a;
}

Vec2 ContactForces::wallsPrototype(std::size_t i, const StepContext& ctx, std::vector<int>& near) const {
    const Vec2& x = ctx.agents.pos[i];
    const double D = ctx.agents.radius[i];
    // Look a little farther than the radius so a centre inside a thick wall still finds its way out.
    ctx.segmentsNear(i, std::max(1.0, 2.0 * D), near);
    Vec2 a(0, 0);
    std::size_t k = 0;
    while (k < near.size()) {
        // Segments are numbered obstacle by obstacle, so one obstacle's segments are contiguous here.
        const int o = ctx.world.segments()[static_cast<std::size_t>(near[k])].obstacle;
        std::size_t end = k;
        while (end < near.size() && ctx.world.segments()[static_cast<std::size_t>(near[end])].obstacle == o) ++end;

        const auto& poly = ctx.world.obstacles()[static_cast<std::size_t>(o)].points;
        const bool inside = poly.size() >= 3 && pointInPolygon(x, poly);
        double bestPen = 0;
        bool bestAdjacent = false;
        Vec2 bestDir(0, 0);
        for (std::size_t m = k; m < end; ++m) {
            const Segment& seg = ctx.world.segments()[static_cast<std::size_t>(near[m])];
            const Vec2 nearest = closestPointOnSegment(x, seg.a, seg.b);
            const Vec2 diff = x - nearest;
            const double d = diff.norm();
            if (inside) {
                // Centre inside: the nearest boundary point decides, pushed outwards by D + d.
                const double pen = D + d;
                if (bestPen == 0 || pen < bestPen) {
                    bestPen = pen;
                    bestDir = d > 1e-12 ? Vec2(-diff / d) : outwardNormal(seg, ctx.world);
                }
                continue;
            }
            if (d >= D) continue;
            const Vec2 ab = seg.b - seg.a;
            const double t = ab.squaredNorm() > 0 ? (x - seg.a).dot(ab) / ab.squaredNorm() : 0.0;
            const bool adjacent = t > 0.0 && t < 1.0;  // foot point inside the segment: faces it
            const double pen = D - d;
            if ((adjacent && !bestAdjacent) || (adjacent == bestAdjacent && pen > bestPen)) {
                bestAdjacent = adjacent;
                bestPen = pen;
                bestDir = d > 1e-12 ? Vec2(diff / d) : outwardNormal(seg, ctx.world);
            }
        }
        a += obstacleStiffness_ * bestPen * bestDir;
        k = end;
    }
    return a;
}

void ContactForces::prepare(const StepContext& ctx) {
    const AgentStore& A = ctx.agents;
    const std::size_t n = A.size();
    // Sized, not zero-filled: the loop below writes every entry, each on the thread that owns the
    // agent (a fill here, on one thread, sent the other thread's half of the array across the
    // cores before its writes, issue 20).
    accel_.resize(n);
    // The search reach D + max D; the scenario's largest radius, known to the simulation, spares a
    // pass over all agents every step (a larger reach only visits more pairs that do not touch).
    double maxRadius = ctx.maxRadius;
    if (!(maxRadius > 0))
        for (double r : A.radius) maxRadius = std::max(maxRadius, r);
    const bool prototype = prototypeWalls();

#pragma omp parallel if (parallelNeighbourLoop(n))
    {
        std::vector<int> near;
        std::vector<NeighbourAgent> agentsNear;  // the grid's agents, where the step's list does not reach
#pragma omp for schedule(static)
        for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            const double D = A.radius[i];
            const double reachMax = D + maxRadius;
            // The step's list, or the grid's agents where it does not reach (tests without lists),
            // through one sum (PairSums.h: eight entries at a time where the CPU has AVX-512).
            pairs::ContactInput in;
            pairs::setList(in, ctx, i, reachMax, agentsNear);
            in.radius = A.radius.data();
            in.radiusI = D;
            in.reach2 = reachMax * reachMax;
            in.stiffness = agentStiffness_;
            Vec2 a = pairs::contactForce(in);
            a += prototype ? wallsPrototype(i, ctx, near) : wallsVanToll(i, ctx, near);
            accel_[i] = a / A.mass[i];
        }
    }
}

Vec2 ContactForces::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    (void)ctx;
    const std::size_t i = static_cast<std::size_t>(q.i);
    return i < accel_.size() ? accel_[i] : Vec2(0, 0);
}

}  // namespace ch
