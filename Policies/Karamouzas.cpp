// CrowdHealth — Karamouzas (Karamouzas & Overmars 2010), see Karamouzas.h.
#include "Karamouzas.h"

#include "crowdhealth/core/geometry.h"

#include <algorithm>
#include <cmath>

namespace ch {

CH_REGISTER_COMPONENT(Karamouzas);

ComponentInfo Karamouzas::Info() {
    ComponentInfo info;
    info.name = "Karamouzas";
    info.kind = ComponentKind::CostFunction;
    info.summary = "velocity selection in a time-to-collision dependent admissible set, goal reaching included";
    info.reference =
        "Karamouzas & Overmars 2010, A velocity-based approach for simulating human collision avoidance, "
        "IVA 2010, LNCS 6356:180-186 (after Karamouzas, Heil, van Beek & Overmars, MIG 2009)";
    ParamSpec tMax = ParamSpec::real("t_max", "s", 8.0, 0.0, 1e3,
                                     "time horizon: collisions later than this are ignored (also the threshold tc_max)");
    tMax.minExclusive = true;
    ParamSpec tcMin = ParamSpec::real("tc_min", "s", 2.5, 0.0, 1e3,
                                      "below this time to collision every speed and up to 90 degrees deviation are allowed");
    tcMin.minExclusive = true;
    info.params = {
        ParamSpec::real("alpha", "-", 5.0, 0.0, 1e6, "weight of the deviation from the preferred direction"),
        ParamSpec::real("beta", "-", 0.5, 0.0, 1e6, "weight of the change of speed"),
        ParamSpec::real("gamma", "-", 1.0, 0.0, 1e6, "weight of the distance to the preferred velocity"),
        ParamSpec::real("delta", "-", 1.0, 0.0, 1e6, "weight of the imminence of the first collision"),
        tMax,
        tcMin,
        ParamSpec::real("tc_mid", "s", 6.0, 0.0, 1e3,
                        "the admissible cone narrows linearly from 30 degrees at tc_mid to ~0 at t_max"),
        ParamSpec::choice("overlap", {"ignore", "closing"}, 0,
                          "a neighbour or wall the agent already overlaps: ignore = left out of every time to "
                          "collision, contact forces separate the pair (UMANS 1.x); closing = an immediate "
                          "collision for velocities that close the gap"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<Karamouzas>(p); };
    return info;
}

Karamouzas::Karamouzas(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "alpha", alpha_);
    bind(params, "beta", beta_);
    bind(params, "gamma", gamma_);
    bind(params, "delta", delta_);
    bind(params, "t_max", tMax_);
    bind(params, "tc_min", tcMin_);
    bind(params, "tc_mid", tcMid_);
    bind(params, "overlap", overlap_);
}

double Karamouzas::timeToFirstCollision(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    return ch::timeToFirstCollision(v, q, ctx, range_, overlap_ == 0 ? OverlapRule::Ignore : OverlapRule::Closing);
}

double Karamouzas::maxDeviation(double ttc) const {
    if (!(ttc < tMax_)) return kDMin;  // no collision within the horizon (also kInf)
    if (ttc < tcMin_) {
        const double s = (tcMin_ - ttc) / tcMin_;
        return kDMid + s * s * (kDMax - kDMid);
    }
    if (ttc < tcMid_) return kDMid;
    // tc_mid ≤ ttc < t_max (so t_max > tc_mid here): linear from d_mid down to d_min.
    return kDMin + (kDMid - kDMin) * (tMax_ - ttc) / (tMax_ - tcMid_);
}

std::pair<double, double> Karamouzas::speedInterval(double ttc, double prefSpeed, double maxSpeed) const {
    const double eps = kSpeedTolerance;
    if (!(ttc < tMax_)) return {prefSpeed - eps, prefSpeed + eps};
    if (ttc < tcMin_) return {0.0, maxSpeed + eps};
    const double spread = std::abs(maxSpeed - prefSpeed);
    return {prefSpeed - spread - eps, prefSpeed + spread + eps};
}

double Karamouzas::cost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    const double prefSpeed = q.prefVelocity.norm();
    const double speed = v.norm();
    // At the goal (no preferred direction): prefer standing still.
    if (prefSpeed <= 1e-12) return speed;

    const double tcPref = timeToFirstCollision(q.prefVelocity, q, ctx);

    // Admissible set: deviation from the preferred direction, then speed.
    // Standing still has no direction: only the speed interval decides whether it is admissible,
    // and its deviation term counts as a 90° turn, so waiting is not cheaper than walking on in
    // the preferred direction (two agents that both wait for the other would wait for ever).
    const bool still = speed <= 1e-12;
    const double cosPhi = still ? 0.0 : std::clamp(v.dot(q.prefVelocity) / (speed * prefSpeed), -1.0, 1.0);
    const double uMax = std::max(q.maxSpeed, 1e-9);
    // How far v lies outside the admissible set: the excess angle in units of 90° plus the excess
    // speed in units of u_max (0 inside).
    double outside = 0;
    if (!still) outside += std::max(0.0, std::acos(cosPhi) - maxDeviation(tcPref)) / kDMax;
    const auto [sMin, sMax] = speedInterval(tcPref, q.prefSpeed, q.maxSpeed);
    outside += (std::max(0.0, sMin - speed) + std::max(0.0, speed - sMax)) / uMax;

    const double tc = timeToFirstCollision(v, q, ctx);
    const double deviation = alpha_ * 0.5 * (1.0 - cosPhi);
    const double speedChange = beta_ * std::abs(speed - q.velocity.norm()) / uMax;
    const double toPreferred = gamma_ * (v - q.prefVelocity).norm() / (2.0 * uMax);
    const double imminence = delta_ * std::max(0.0, tMax_ - tc) / tMax_;
    const double c = deviation + speedChange + toPreferred + imminence;
    // Inadmissible velocities are not forbidden outright but ranked after every admissible one,
    // nearest to the admissible set first (see the class comment).
    return outside > 0 ? kOutsidePenalty * (1.0 + outside) + c : c;
}

}  // namespace ch
