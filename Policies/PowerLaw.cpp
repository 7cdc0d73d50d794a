// CrowdHealth — PowerLaw (Karamouzas, Skinner & Guy 2014), see PowerLaw.h.
#include "PowerLaw.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(PowerLaw);

namespace {

/// Time to collision τ > 0 of two discs (radius sum R) at relative position x moving at relative
/// velocity v, and ∇_x τ. False when they overlap now or never touch in the future.
bool collisionTime(const Vec2& x, const Vec2& v, double R, double& tau, Vec2& gradTau) {
    const double c = x.squaredNorm() - R * R;
    if (c <= 0) return false;
    const double a = v.squaredNorm();
    if (a <= 1e-12) return false;
    const double b = -x.dot(v);
    const double disc = b * b - a * c;
    if (disc <= 0) return false;  // passing by (or grazing)
    const double root = std::sqrt(disc);
    tau = (b - root) / a;  // the earlier root; with c > 0 both roots share the sign of b
    if (!(tau > 0)) return false;
    gradTau = (x + tau * v) / root;
    return true;
}

/// The same for a disc of radius r at p moving at v against the static segment [a, b]: the
/// earliest of the contacts with either endpoint and with the interior.
bool wallCollisionTime(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b, double& tau,
                       Vec2& gradTau) {
    if (distanceToSegmentSquared(p, a, b) <= r * r) return false;  // touching now: contact forces act
    bool found = false;
    tau = kInf;
    for (const Vec2* e : {&a, &b}) {
        double t;
        Vec2 g;
        if (collisionTime(p - *e, v, r, t, g) && t < tau) {
            tau = t;
            gradTau = g;
            found = true;
        }
    }
    const Vec2 ab = b - a;
    const double len = ab.norm();
    if (len > 1e-12) {
        Vec2 n(-ab.y() / len, ab.x() / len);
        double s = (p - a).dot(n);
        if (s < 0) {
            n = -n;
            s = -s;
        }
        const double u = -v.dot(n);  // approach speed towards the supporting line
        if (u > 1e-12 && s > r) {
            const double t = (s - r) / u;
            const double along = (p + v * t - a).dot(ab) / (len * len);
            if (along >= 0 && along <= 1 && t < tau) {
                tau = t;
                gradTau = n / u;
                found = true;
            }
        }
    }
    return found;
}

}  // namespace

ComponentInfo PowerLaw::Info() {
    ComponentInfo info;
    info.name = "PowerLaw";
    info.kind = ComponentKind::Force;
    info.summary = "anticipatory force from the energy k/tau^2 exp(-tau/tau0) of the time to collision tau";
    info.reference =
        "Karamouzas, Skinner & Guy 2014, Universal power law governing pedestrian interactions, "
        "Phys. Rev. Lett. 113:238701";
    ParamSpec tau0 = ParamSpec::real("tau0", "s", 3.0, 0.0, 1e3,
                                     "interaction time horizon: exponential cut-off, and no interaction beyond it");
    tau0.minExclusive = true;
    info.params = {
        ParamSpec::real("k", "m2", 1.5, 0.0, 1e6, "scale of the interaction energy (per unit mass)"),
        tau0,
        ParamSpec::boolean("walls", true,
                           "apply the same law to wall segments (UMANS ignores walls: false)"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<PowerLaw>(p); };
    return info;
}

PowerLaw::PowerLaw(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "k", k_);
    bind(params, "tau0", tau0_);
    bind(params, "walls", walls_);
}

double PowerLaw::forceFactor(double tau) const {
    // −dE/dτ for E = k τ^-2 e^{-τ/τ0}.
    return k_ * std::exp(-tau / tau0_) / (tau * tau) * (2.0 / tau + 1.0 / tau0_);
}

double PowerLaw::pairEnergy(const Vec2& x, const Vec2& v, double R) const {
    double tau;
    Vec2 g;
    if (!collisionTime(x, v, R, tau, g) || tau > tau0_) return 0.0;
    return k_ / (tau * tau) * std::exp(-tau / tau0_);
}

Vec2 PowerLaw::pairForce(const Vec2& x, const Vec2& v, double R) const {
    double tau;
    Vec2 g;
    if (!collisionTime(x, v, R, tau, g) || tau > tau0_) return {0, 0};
    return forceFactor(tau) * g;
}

double PowerLaw::wallEnergy(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b) const {
    double tau;
    Vec2 g;
    if (!wallCollisionTime(p, v, r, a, b, tau, g) || tau > tau0_) return 0.0;
    return k_ / (tau * tau) * std::exp(-tau / tau0_);
}

Vec2 PowerLaw::wallForce(const Vec2& p, const Vec2& v, double r, const Vec2& a, const Vec2& b) const {
    double tau;
    Vec2 g;
    if (!wallCollisionTime(p, v, r, a, b, tau, g) || tau > tau0_) return {0, 0};
    return forceFactor(tau) * g;
}

Vec2 PowerLaw::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    const AgentStore& A = ctx.agents;
    Vec2 f(0, 0);
    for (const NeighbourAgent& n : q.agents) {
        if (n.distanceSquared() > range_ * range_) continue;
        f += pairForce(-n.offset, q.velocity - A.vel[n.index], q.radius + A.radius[n.index]);
    }
    if (walls_ != 0) {
        for (int s : q.segments) {
            const Segment& seg = ctx.world.segments()[s];
            if (distanceToSegmentSquared(q.position, seg.a, seg.b) > range_ * range_) continue;
            f += wallForce(q.position, q.velocity, q.radius, seg.a, seg.b);
        }
    }
    return f / q.mass;
}

}  // namespace ch
