// CrowdHealth — TtcaDca (Dutra, Marques, Cavalcante-Neto, Vidal & Pettré 2017).
#include "TtcaDca.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(TtcaDca);

ComponentInfo TtcaDca::Info() {
    ComponentInfo info;
    info.name = "TtcaDca";
    info.kind = ComponentKind::CostFunction;
    info.summary = "vision-based cost on time and distance to closest approach plus goal terms "
                   "(analytic gradient; use with the gradient method)";
    info.reference = "Dutra, Marques, Cavalcante-Neto, Vidal & Pettre 2017, Gradient-based steering for "
                     "vision-based crowd simulation algorithms, Computer Graphics Forum 36(2):337";
    info.params = {
        ParamSpec::real("sigmaTtca", "s", 1.0, 0.0, 1e3, "width of the Gaussian on the time to closest approach"),
        ParamSpec::real("sigmaDca", "m", 0.3, 0.0, 1e3, "width of the Gaussian on the distance at closest approach"),
        ParamSpec::real("sigmaAngle_goal", "rad", 2.0, 0.0, 1e3,
                        "width of the Gaussian on the angle between velocity and preferred velocity"),
        ParamSpec::real("sigmaSpeed_goal", "m/s", 2.0, 0.0, 1e3,
                        "width of the Gaussian on the difference to the preferred speed"),
        ParamSpec::real("fov", "deg", 180.0, 0.0, 360.0, "horizontal field of view of the synthetic camera"),
        ParamSpec::integer("pixels", 256, 1, 100000, "number of pixel rays across the field of view"),
        ParamSpec::choice("vision", {"pixels", "umans"}, 1,
                          "pixels = rendered pixel rays, gradient in velocity space; umans = one term per "
                          "neighbour in front, weighted by 1/distance^2, derivatives in (heading, speed) space "
                          "mapped back as UMANS 1.x does"),
    };
    for (int k = 0; k < 5; ++k) info.params[k].minExclusive = true;
    info.create = [](const ParamSet& p) { return std::make_unique<TtcaDca>(p); };
    return info;
}

TtcaDca::TtcaDca(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "sigmaTtca", sigmaTtca_);
    bind(params, "sigmaDca", sigmaDca_);
    bind(params, "sigmaAngle_goal", sigmaAngle_);
    bind(params, "sigmaSpeed_goal", sigmaSpeed_);
    bind(params, "fov", fovDeg_);
    bind(params, "pixels", pixels_);
    bind(params, "vision", vision_);
}

namespace {

/// Distance along the unit ray e from the origin to the disc D(c, R) (origin outside), or kInf.
double rayDisc(const Vec2& e, const Vec2& c, double R) {
    const double b = e.dot(c);
    if (b <= 0) return kInf;
    const double disc = b * b - (c.squaredNorm() - R * R);
    if (disc < 0) return kInf;
    return b - std::sqrt(disc);
}

/// Distance along the unit ray e from the origin to the segment [a, b] grown by r (origin outside).
double rayCapsule(const Vec2& e, const Vec2& a, const Vec2& b, double r) {
    double t = std::min(rayDisc(e, a, r), rayDisc(e, b, r));
    const Vec2 ab = b - a;
    const double L = ab.norm();
    if (L <= 0) return t;
    const Vec2 tau = ab / L;
    Vec2 n(-tau.y(), tau.x());
    double delta = -a.dot(n);  // signed distance of the origin from the segment's line
    if (delta < 0) {
        n = -n;
        delta = -delta;
    }
    const double en = e.dot(n);
    if (en < 0) {
        const double ts = (r - delta) / en;
        const double lambda = (ts * e - a).dot(tau);
        if (ts >= 0 && lambda >= 0 && lambda <= L) t = std::min(t, ts);
    }
    return t;
}

double signedAngle(const Vec2& from, const Vec2& to) {
    return std::atan2(from.x() * to.y() - from.y() * to.x(), from.dot(to));
}

}  // namespace

void TtcaDca::perceive(const AgentQuery& q, const StepContext& ctx, std::vector<Pixel>& out) const {
    out.clear();
    const AgentStore& A = ctx.agents;
    Vec2 heading = normalisedOrZero(A.viewDir[q.i]);
    if (heading.squaredNorm() == 0) heading = normalisedOrZero(q.velocity);
    if (heading.squaredNorm() == 0) heading = Vec2(1, 0);

    const int W = std::max(1, static_cast<int>(std::lround(pixels_)));
    const double fov = fovDeg_ * kPi / 180.0;
    const double dPhi = fov / W;
    // A quarter-pixel offset: no ray lies exactly on the viewing direction (see the class comment).
    auto phiOf = [&](int k) { return -0.5 * fov + (k + 0.25) * dPhi; };

    std::vector<double> depth(W, kInf);
    std::vector<Vec2> vel(W, Vec2(0, 0));
    std::vector<Vec2> dir(W);
    for (int k = 0; k < W; ++k) dir[k] = rotated(heading, phiOf(k));

    auto splat = [&](int k, double t, const Vec2& u) {
        if (t < depth[k]) {
            depth[k] = t;
            vel[k] = u;
        }
    };

    for (const NeighbourAgent& n : q.agents) {
        const double d2 = n.distanceSquared();
        if (d2 > range_ * range_) continue;
        const double R = q.radius + A.radius[n.index];
        const Vec2& u = A.vel[n.index];
        if (d2 <= R * R) {
            // Already overlapping: the camera is inside the grown disc; it sees the centre.
            out.push_back({n.offset, u});
            continue;
        }
        const double bearing = signedAngle(heading, n.offset);
        const double half = std::asin(std::min(1.0, R / std::sqrt(d2)));
        int k0 = 0, k1 = W - 1;
        const bool wraps = fov > 2 * kPi - 1e-9 && (bearing - half < -kPi || bearing + half > kPi);
        if (!wraps) {
            k0 = std::max(0, static_cast<int>(std::floor((bearing - half + 0.5 * fov) / dPhi - 0.25)) - 1);
            k1 = std::min(W - 1, static_cast<int>(std::ceil((bearing + half + 0.5 * fov) / dPhi - 0.25)) + 1);
        }
        for (int k = k0; k <= k1; ++k) {
            const double t = rayDisc(dir[k], n.offset, R);
            if (t < kInf) splat(k, t, u);
        }
    }
    for (int s : q.segments) {
        const Segment& seg = ctx.world.segments()[s];
        const Vec2 a = seg.a - q.position, b = seg.b - q.position;
        const Vec2 nearest = closestPointOnSegment(Vec2(0, 0), a, b);
        const double d2 = nearest.squaredNorm();
        if (d2 > range_ * range_) continue;
        if (d2 <= q.radius * q.radius) {
            out.push_back({nearest, Vec2(0, 0)});
            continue;
        }
        for (int k = 0; k < W; ++k) {
            const double t = rayCapsule(dir[k], a, b, q.radius);
            if (t < kInf) splat(k, t, Vec2(0, 0));
        }
    }
    for (int k = 0; k < W; ++k)
        if (depth[k] < kInf) out.push_back({depth[k] * dir[k], vel[k]});
}

double TtcaDca::pixelCost(const Vec2& v, const Pixel& px, Vec2* grad) const {
    const Vec2& p = px.point;
    const Vec2 w = px.velocity - v;  // the point's velocity relative to the agent
    const double ww = w.squaredNorm();
    double ttca = ww > 1e-12 ? -p.dot(w) / ww : 0.0;
    const bool clamped = ttca <= 0.0;
    if (clamped) ttca = 0.0;
    const Vec2 dvec = p + ttca * w;
    const double dca = dvec.norm();
    const double st2 = sigmaTtca_ * sigmaTtca_, sd2 = sigmaDca_ * sigmaDca_;
    const double c = std::exp(-0.5 * (ttca * ttca / st2 + dca * dca / sd2));
    if (grad != nullptr && !clamped) {
        // With respect to w (∂w/∂v = −I):
        //   ∂ttca/∂w = −(p + 2·ttca·w)/|w|²,  ∂dca/∂w = ttca·d̂ + (w·d̂)·∂ttca/∂w  (w·d̂ = 0 here).
        const Vec2 dTtca = -(p + 2.0 * ttca * w) / ww;
        Vec2 dDca(0, 0);
        if (dca > 1e-12) {
            const Vec2 dhat = dvec / dca;
            dDca = ttca * dhat + w.dot(dhat) * dTtca;
        }
        const Vec2 dcdw = -c * (ttca / st2 * dTtca + dca / sd2 * dDca);
        *grad -= dcdw;
    }
    return c;
}

double TtcaDca::movementCost(const Vec2& v, const AgentQuery& q, Vec2* grad) const {
    const double s = v.norm();
    const double ps = q.prefVelocity.norm();
    const bool moving = s > 1e-9;
    const double alpha = (moving && ps > 1e-9) ? signedAngle(q.prefVelocity, v) : 0.0;
    const double sa2 = sigmaAngle_ * sigmaAngle_, ss2 = sigmaSpeed_ * sigmaSpeed_;
    const double cAngle = std::exp(-0.5 * alpha * alpha / sa2);
    const double ds = s - ps;
    const double cSpeed = std::exp(-0.5 * ds * ds / ss2);
    if (grad != nullptr) {
        // At v = 0 the speed term has no gradient direction; take the preferred one (an agent at
        // rest starts walking towards its goal).
        const Vec2 vhat = moving ? Vec2(v / s) : normalisedOrZero(q.prefVelocity);
        Vec2 dAngle(0, 0);
        if (moving && ps > 1e-9) dAngle = -cAngle * alpha / sa2 * Vec2(-v.y(), v.x()) / (s * s);
        const Vec2 dSpeed = -cSpeed * ds / ss2 * vhat;
        *grad += -0.5 * (dAngle + dSpeed);
    }
    return 1.0 - 0.5 * (cAngle + cSpeed);
}

namespace {
/// Signed angle (rad) that turns a onto b, counter-clockwise positive; 0 if either is zero.
double turnAngle(const Vec2& a, const Vec2& b) {
    if (a.squaredNorm() == 0 || b.squaredNorm() == 0) return 0.0;
    return std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
}
}  // namespace

TtcaDca::NeighbourTerm TtcaDca::neighbourTerm(const Vec2& v, const AgentQuery& q, const StepContext& ctx,
                                               const NeighbourAgent& n) const {
    // UMANS 1.x's per-neighbour approximation of the pixels: the centre-to-centre offset shortened
    // by both radii, the relative velocity with a correction along the offset's normal (not
    // normalised, as there), ttca ≥ 0, and the derivatives of the paper (eq. 29–37) in
    // (heading, speed) space.
    NeighbourTerm t;
    const Vec2 p = n.offset;
    const double pm = p.norm();
    if (pm <= 1e-12) return t;
    const Vec2 dp = p / pm * (pm - q.radius - ctx.agents.radius[n.index]);
    const Vec2 dvc = ctx.agents.vel[n.index] - v;
    const Vec2 normal(-p.y(), p.x());
    const Vec2 dv = dvc + normal * normal.dot(dvc);
    const double dv2 = dv.squaredNorm();
    const double ttca = dv2 == 0 ? 0.0 : std::max(0.0, -dp.dot(dv) / dv2);
    const Vec2 atClosest = dp + dv * ttca;
    const double dca = atClosest.norm();
    const double st2 = sigmaTtca_ * sigmaTtca_, sd2 = sigmaDca_ * sigmaDca_;
    t.cost = std::exp(-0.5 * (ttca * ttca / st2 + dca * dca / sd2));
    t.weight = 1.0 / std::max(dp.squaredNorm(), 1e-12);
    t.valid = true;
    constexpr double kSmall = 1e-3;  // below this the derivatives are unreliable (UMANS' eps)
    if (dv2 <= kSmall) {
        t.derivable = false;
        return t;
    }
    const Vec2 turned(dv.y(), -dv.x());
    const Vec2 along = dv / std::sqrt(dv2);
    double tHeading = 0, tSpeed = 0;
    if (std::abs(ttca) > kSmall) {
        const Vec2 rel = dp + 2 * ttca * dv;
        tHeading = -rel.dot(turned) / dv2;
        tSpeed = rel.dot(along) / dv2;
    }
    double dHeading = 0, dSpeed = 0;
    if (dca > kSmall) {
        dHeading = atClosest.dot(tHeading * dv + ttca * turned) / dca;
        dSpeed = atClosest.dot(tSpeed * dv - ttca * along) / dca;
    }
    t.heading = -t.cost * (tHeading * ttca / st2 + dHeading * dca / sd2);
    t.speed = -t.cost * (tSpeed * ttca / st2 + dSpeed * dca / sd2);
    return t;
}

bool TtcaDca::inView(const AgentQuery& q, const NeighbourAgent& n) const {
    // In front of the agent's current velocity (UMANS: a half-angle of fov/2 around it).
    const double a = std::abs(turnAngle(q.velocity, n.offset));
    return a <= 0.5 * fovDeg_ * kPi / 180.0;
}

double TtcaDca::umansCost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    double sum = 0, weights = 0;
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() >= range_ * range_ || !inView(q, n)) continue;
        const NeighbourTerm t = neighbourTerm(v, q, ctx, n);
        if (!t.valid) continue;
        sum += t.cost * t.weight;
        weights += t.weight;
    }
    const double alpha = std::abs(turnAngle(v, q.prefVelocity));
    const double ds = v.norm() - q.prefSpeed;
    const double cm = 1.0 - 0.5 * (std::exp(-0.5 * alpha * alpha / (sigmaAngle_ * sigmaAngle_)) +
                                   std::exp(-0.5 * ds * ds / (sigmaSpeed_ * sigmaSpeed_)));
    return cm + (weights > 0 ? sum / weights : 0.0);
}

Vec2 TtcaDca::umansGradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    double heading = 0, speed = 0, weights = 0;
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_ || !inView(q, n)) continue;
        const NeighbourTerm t = neighbourTerm(v, q, ctx, n);
        if (!t.valid || !t.derivable) continue;
        heading += t.heading * t.weight;
        speed += t.speed * t.weight;
        weights += t.weight;
    }
    if (weights > 0) {
        heading /= weights;
        speed /= weights;
    }
    // The goal terms (paper eq. 14–15), with UMANS' factor 1/(2σ²).
    const double alpha = turnAngle(v, q.prefVelocity);
    const double ds = v.norm() - q.prefSpeed;
    const double sa2 = sigmaAngle_ * sigmaAngle_, ss2 = sigmaSpeed_ * sigmaSpeed_;
    heading += alpha / (2 * sa2) * std::exp(-0.5 * alpha * alpha / sa2);
    speed += ds / (2 * ss2) * std::exp(-0.5 * ds * ds / ss2);
    // Back to velocity space as UMANS does: a heading derivative h turns the velocity by the angle
    // h (sideways sin h·|v|, backwards (1 − cos h)·|v|), a speed derivative acts along it. Nearly at
    // rest the preferred velocity gives the frame, so the agent starts walking.
    Vec2 dir = normalisedOrZero(v);
    double s = v.norm();
    if (v.squaredNorm() < 0.01) {
        dir = normalisedOrZero(q.prefVelocity);
        s = q.prefVelocity.norm();
    }
    const Vec2 right(dir.y(), -dir.x());
    return right * (std::sin(heading) * s) + dir * ((1 - std::cos(heading)) * s + speed);
}

double TtcaDca::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    if (vision_ == kVisionUmans) return umansCost(v, q, ctx);
    std::vector<Pixel> view;
    perceive(q, ctx, view);
    double obstacle = 0;
    for (const Pixel& px : view) obstacle += pixelCost(v, px, nullptr);
    if (!view.empty()) obstacle /= static_cast<double>(view.size());
    return movementCost(v, q, nullptr) + obstacle;
}

Vec2 TtcaDca::gradient(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    if (vision_ == kVisionUmans) return umansGradient(v, q, ctx);
    std::vector<Pixel> view;
    perceive(q, ctx, view);
    Vec2 g(0, 0);
    for (const Pixel& px : view) pixelCost(v, px, &g);
    if (!view.empty()) g /= static_cast<double>(view.size());
    movementCost(v, q, &g);
    return g;
}

}  // namespace ch
