// CrowdHealth — SocialForcesAvoidance (Helbing & Molnár 1995).
#include "SocialForcesAvoidance.h"

#include "SocialForcesSimd.h"

#include <algorithm>
#include <cmath>
#include <span>

namespace ch {

namespace {

/// What the pair loop needs besides the neighbour list (one agent's call).
struct PairLoop {
    const SocialForcesAvoidance::Other* other;  ///< per agent: its step, |step|², radius
    Vec2 ownStep;            ///< with relative velocities: the agent's own v Δt (subtracted)
    bool relative, cutoff, headingZero;
    double ownRadius, range, cosFov, behind, V0, sigma;
    Vec2 heading;
};

/// Σ_j w_j f_j over the neighbour list: the elliptic pair force of pairForce() and the field-of-view
/// weight, simd::kLanes (4) pairs at a time (issue 20). Pairs that exert no force (beyond range, in contact,
/// degenerate ellipse) are masked to +0. The sum runs over the list in order, one term after the
/// other, so it does not depend on how the lanes are grouped. The terms differ from pairForce()'s
/// in the last bits: the exponential is simd::expNonPositive (within 5e-16 of std::exp) and the
/// gradient takes one division instead of three (∇b = (|R| + |R−s|)/(4b|R||R−s|) ·
/// (R|R−s| + (R−s)|R|)). With std::exp and pairForce()'s three divisions this loop gave the bits
/// of the scalar loop it replaced, every state hash of crowdhealth-bench unchanged.
/// Compiled twice (AVX2 and generic x86-64, chosen when the program starts): the same operations
/// without fused multiply-add, so both give the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
Vec2 pedestrianForces(std::span<const NeighbourAgent> list, const PairLoop& in) {
    using simd::DV;
    using simd::IV;
    using simd::splat;
    const std::size_t m = list.size();
    const double invSigma = 1.0 / in.sigma;
    const DV range = splat(in.range), ownRadius = splat(in.ownRadius), behind = splat(in.behind);
    const DV hx = splat(in.heading.x()), hy = splat(in.heading.y()), cosFov = splat(in.cosFov);
    const DV ownSx = splat(in.ownStep.x()), ownSy = splat(in.ownStep.y());
    const DV zero = splat(0.0), half = splat(0.5), four = splat(4.0), one = splat(1.0);
    const DV vOverSigma = splat(in.V0 * invSigma), invS = splat(invSigma);
    double fx = 0, fy = 0;
    for (std::size_t k0 = 0; k0 < m; k0 += simd::kLanes) {
        // Gather kLanes neighbours (the last block repeats its last one in the unused lanes, masked).
        DV ox, oy, sx, sy, ssq, rj;
        IV live;
        for (int l = 0; l < simd::kLanes; ++l) {
            const std::size_t k = std::min(k0 + static_cast<std::size_t>(l), m - 1);
            const NeighbourAgent& n = list[k];
            const SocialForcesAvoidance::Other& o = in.other[n.index];
            ox[l] = n.offset.x();
            oy[l] = n.offset.y();
            sx[l] = o.sx;
            sy[l] = o.sy;
            ssq[l] = o.stepSq;
            rj[l] = o.radius;
            live[l] = k0 + static_cast<std::size_t>(l) < m ? -1 : 0;
        }
        const DV distance = simd::sqrt(ox * ox + oy * oy);  // NeighbourAgent::distance()
        IV use = live & (distance <= range);
        if (in.cutoff) use &= distance > ownRadius + rj;  // in contact: contact forces act
        if (in.relative) {
            sx = sx - ownSx;
            sy = sy - ownSy;
            ssq = sx * sx + sy * sy;
        }
        // pairForce(R = −offset, |R|, s, |s|²).
        const DV Rx = -ox, Ry = -oy;
        const DV R2x = Rx - sx, R2y = Ry - sy;
        const DV magR2 = simd::sqrt(R2x * R2x + R2y * R2y);
        const DV sum = distance + magR2;
        const DV twoBSquared = sum * sum - ssq;
        use &= (twoBSquared > zero) & (distance >= splat(1e-9)) & (magR2 >= splat(1e-9));
        const DV b = half * simd::sqrt(simd::select(use, twoBSquared, one));
        use &= b >= splat(1e-3);
        // ∇b = (|R| + |R−s|)/(4b) · (R/|R| + (R−s)/|R−s|), over one common denominator.
        const DV c = sum / (four * b * distance * magR2);
        const DV gx = c * (Rx * magR2 + R2x * distance), gy = c * (Ry * magR2 + R2y * distance);
        const DV a = vOverSigma * simd::expNonPositive(-b * invS);
        // Eq. 8: full weight when the neighbour is within the field of view.
        IV inView = hx * ox + hy * oy >= cosFov * distance;
        if (in.headingZero) inView = inView | ~inView;
        const DV w = simd::select(inView, one, behind);
        const DV tx = simd::select(use, w * (a * gx), zero), ty = simd::select(use, w * (a * gy), zero);
        for (int l = 0; l < simd::kLanes; ++l) {
            fx += tx[l];
            fy += ty[l];
        }
    }
    return Vec2(fx, fy);
}

}  // namespace

CH_REGISTER_COMPONENT(SocialForcesAvoidance);

ComponentInfo SocialForcesAvoidance::Info() {
    ComponentInfo info;
    info.name = "SocialForcesAvoidance";
    info.kind = ComponentKind::Force;
    info.summary = "repulsive social forces from pedestrians (elliptic potential) and walls";
    info.reference = "Helbing & Molnar 1995, Social force model for pedestrian dynamics, Phys. Rev. E 51(5):4282";
    info.params = {
        ParamSpec::real("dt", "s", 2.0, 0.0, 60.0, "time horizon of the other's step in the elliptic potential (eq. 4)"),
        ParamSpec::real("V0", "m2/s2", 2.1, 0.0, 1e4, "strength of the pedestrian repulsion potential (eq. 13)"),
        ParamSpec::real("sigma", "m", 0.3, 1e-6, 100.0, "decay length of the pedestrian potential (eq. 13)"),
        ParamSpec::real("U0", "m2/s2", 10.0, 0.0, 1e4, "strength of the wall repulsion potential (eq. 13)"),
        ParamSpec::real("R", "m", 0.2, 1e-6, 100.0, "decay length of the wall potential (eq. 13)"),
        ParamSpec::real("fov", "deg", 100.0, 0.0, 180.0, "half-angle of the field of view (eq. 8)"),
        ParamSpec::real("behind", "-", 0.5, 0.0, 1.0, "weight of interactions outside the field of view (eq. 8)"),
        ParamSpec::choice("otherVelocity", {"preferred", "relative"}, 0,
                          "the other's motion in b (eq. 4): preferred = its speed along its preferred direction, "
                          "v_b dt e_b (Helbing & Molnar 1995); relative = (v_b - v_a) dt (UMANS 1.x)"),
        ParamSpec::boolean("contactCutoff", true,
                           "pairs whose bodies overlap exert no social force (contact forces take over); false: "
                           "the force acts at every distance (UMANS 1.x)"),
        ParamSpec::choice("walls", {"nearest", "umans"}, 0,
                          "nearest = one force per obstacle from its nearest point, full weight; umans = one per "
                          "wall segment whose outer side faces the agent (polygons counter-clockwise, taken as "
                          "listed), a shared corner once, weighted by fov/behind (UMANS 1.x)"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<SocialForcesAvoidance>(p); };
    return info;
}

SocialForcesAvoidance::SocialForcesAvoidance(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "dt", dt_);
    bind(params, "V0", V0_);
    bind(params, "sigma", sigma_);
    bind(params, "U0", U0_);  // UMANS reads U0 into V0 by mistake; we keep them apart
    bind(params, "R", R_);
    bind(params, "fov", fovDeg_);
    bind(params, "behind", behind_);
    bind(params, "otherVelocity", otherVelocity_);
    bind(params, "contactCutoff", contactCutoff_);
    bind(params, "walls", walls_);
}

Vec2 SocialForcesAvoidance::pairForce(const Vec2& R, double vb, const Vec2& eb) const {
    const Vec2 step = vb * dt_ * eb;
    return pairForce(R, R.norm(), step, step.squaredNorm());
}

Vec2 SocialForcesAvoidance::pairForce(const Vec2& R, double magR, const Vec2& step, double stepSq) const {
    const Vec2 R2 = R - step;
    const double magR2 = R2.norm();
    const double sum = magR + magR2;
    const double twoBSquared = sum * sum - stepSq;  // (2b)²
    if (twoBSquared <= 0 || magR < 1e-9 || magR2 < 1e-9) return {0, 0};
    const double b = 0.5 * std::sqrt(twoBSquared);
    if (b < 1e-3) return {0, 0};
    // ∇_R b = (|R| + |R−s|)/(4b) · (R/|R| + (R−s)/|R−s|); f = −dV/db ∇b = V0/σ e^{−b/σ} ∇b.
    // (Three divisions per pair: this runs for every neighbour within 5 m.)
    const double inv1 = 1.0 / magR, inv2 = 1.0 / magR2, invSigma = 1.0 / sigma_;
    const Vec2 gradB = (sum / (4.0 * b)) * (R * inv1 + R2 * inv2);
    return V0_ * invSigma * std::exp(-b * invSigma) * gradB;
}

void SocialForcesAvoidance::prepare(const StepContext& ctx) {
    // The neighbour's step v_β Δt e_β depends on the neighbour only: computed once per agent here
    // instead of once per pair (a norm and a normalisation saved in the O(N·k) loop). With relative
    // velocities the pair's step (v_β − v_α)Δt is step_[j] − step_[i], step_ = v Δt.
    const AgentStore& A = ctx.agents;
    const std::size_t n = A.size();
    const bool relative = otherVelocity_ != 0;
    step_.resize(n);
    other_.resize(n);
    for (std::size_t j = 0; j < n; ++j) {
        step_[j] = relative ? Vec2(dt_ * A.vel[j]) : Vec2(A.vel[j].norm() * dt_ * normalisedOrZero(A.prefVel[j]));
        // What the pair loop reads of a neighbour, in one 32-byte record (one cache line).
        other_[j] = Other{step_[j].x(), step_[j].y(), relative ? 0.0 : step_[j].squaredNorm(), A.radius[j]};
    }
}

Vec2 SocialForcesAvoidance::wallForce(const Vec2& diff) const {
    const double d = diff.norm();
    if (d < 1e-3) return {0, 0};
    return U0_ / R_ * std::exp(-d / R_) * (diff / d);
}

Vec2 SocialForcesAvoidance::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    // Walking direction for the field of view: the velocity, or the preferred one when at rest.
    Vec2 heading = normalisedOrZero(q.velocity);
    if (heading.squaredNorm() == 0) heading = normalisedOrZero(q.prefVelocity);
    const double cosFov = std::cos(fovDeg_ * kPi / 180.0);

    const bool relative = otherVelocity_ != 0;
    PairLoop in;
    in.other = other_.data();
    in.ownStep = relative ? Vec2(step_[static_cast<std::size_t>(q.i)]) : Vec2(0, 0);
    in.relative = relative;
    in.cutoff = contactCutoff_ != 0;
    in.headingZero = heading.squaredNorm() == 0;
    in.ownRadius = q.radius;
    in.range = range_;
    in.cosFov = cosFov;
    in.behind = behind_;
    in.V0 = V0_;
    in.sigma = sigma_;
    in.heading = heading;
    Vec2 f = q.agents.empty() ? Vec2(0, 0) : pedestrianForces(q.agents, in);
    if (walls_ != 0) return (f + wallsUmans(q, ctx, heading, cosFov)) / q.mass;
    // Walls: one force per obstacle, from its nearest point (Helbing & Molnár's "nearest point of
    // the border"). Summing over segments would count a convex corner twice — its two edges share
    // the nearest point — and push agents back from door jambs with double strength. The query's
    // segments are ascending by index and an obstacle's edges are consecutive.
    const auto& segments = ctx.world.segments();
    std::size_t k = 0;
    while (k < q.segments.size()) {
        const int obstacle = segments[q.segments[k]].obstacle;
        Vec2 nearest(0, 0);
        double best = kInf;
        for (; k < q.segments.size() && segments[q.segments[k]].obstacle == obstacle; ++k) {
            const Segment& seg = segments[q.segments[k]];
            const Vec2 diff = q.position - closestPointOnSegment(q.position, seg.a, seg.b);
            if (diff.squaredNorm() < best) {
                best = diff.squaredNorm();
                nearest = diff;
            }
        }
        if (std::sqrt(best) <= range_) f += wallForce(nearest);
    }
    return f / q.mass;
}

Vec2 SocialForcesAvoidance::wallsUmans(const AgentQuery& q, const StepContext& ctx, const Vec2& heading,
                                       double cosFov) const {
    // UMANS 1.x: every obstacle edge in range counts, except (1) an edge the agent lies behind
    // (inside the obstacle, or the far face of a thick wall) and (2) an edge whose nearest point is
    // its end corner: walking a polygon counter-clockwise, the next edge starts at that corner, so
    // a convex corner pushes once. Each force is weighted like a pedestrian at the nearest point
    // (full inside the field of view, `behind` outside). As in UMANS the edges are taken as listed
    // and "behind" means left of a→b, which is right for counter-clockwise polygons (UMANS'
    // convention, its example files, our <Box>); a clockwise polygon keeps its far faces instead.
    const auto& segments = ctx.world.segments();
    Vec2 f(0, 0);
    for (const int k : q.segments) {
        const Segment& seg = segments[static_cast<std::size_t>(k)];
        const Vec2& a = seg.a;
        const Vec2& b = seg.b;
        const Vec2 ab = b - a;
        const Vec2 ap = q.position - a;
        if (ab.x() * ap.y() - ab.y() * ap.x() > 0) continue;  // left of a→b: the inner side
        const double len2 = ab.squaredNorm();
        const double t = len2 > 0 ? ap.dot(ab) / len2 : 0.0;
        if (t >= 1.0) continue;  // nearest point is its end corner: the next edge takes it
        const Vec2 diff = t <= 0.0 ? ap : Vec2(ap - t * ab);
        if (diff.squaredNorm() > range_ * range_) continue;
        const double d = diff.norm();
        const bool inView = heading.squaredNorm() == 0 || d < 1e-9 || heading.dot(-diff / d) >= cosFov;
        f += (inView ? 1.0 : behind_) * wallForce(diff);
    }
    return f;
}

}  // namespace ch
