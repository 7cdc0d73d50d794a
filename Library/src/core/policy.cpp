// CrowdHealth — policy steps and optimisation methods.
#include "crowdhealth/core/policy.h"

#include "crowdhealth/core/registry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ch {

PolicyStep::PolicyStep(const StepSpec& spec) : spec_(spec) {
    for (const ComponentSpec& c : spec.components) {
        Entry e{createComponent(c.name, c.params), c.coeff, c.name};
        range_ = std::max(range_, e.component->range());
        components_.push_back(std::move(e));
    }
}

void PolicyStep::prepare(const StepContext& ctx) {
    for (Entry& e : components_) e.component->prepare(ctx);
}

double PolicyStep::totalCost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const {
    double sum = 0;
    for (const Entry& e : components_) sum += e.coeff * e.component->cost(v, q, ctx);
    return sum;
}

SamplingSpec PolicyStep::denseSampling() {
    SamplingSpec s;
    s.type = SamplingSpec::Type::Regular;
    s.base = SamplingSpec::Base::Zero;
    s.baseDirection = SamplingSpec::BaseDirection::Unit;
    s.radius = SamplingSpec::Radius::MaximumSpeed;
    s.angle = 360;
    s.speedSamples = 21;
    s.angleSamples = 72;
    s.includeBaseAsSample = true;
    return s;
}

Vec2 PolicyStep::bestVelocitySampling(const AgentQuery& q, const StepContext& ctx, const SamplingSpec& s) const {
    const Vec2 base = s.base == SamplingSpec::Base::CurrentVelocity ? q.velocity : Vec2(0, 0);
    double radius = q.prefSpeed;
    if (s.radius == SamplingSpec::Radius::MaximumSpeed) radius = q.maxSpeed;
    else if (s.radius == SamplingSpec::Radius::MaximumAcceleration)
        radius = std::min(2.0 * q.maxSpeed, q.maxAcceleration * ctx.dt);

    Vec2 dir(1, 0);
    if (s.baseDirection == SamplingSpec::BaseDirection::CurrentVelocity) dir = normalisedOrZero(q.velocity);
    else if (s.baseDirection == SamplingSpec::BaseDirection::PreferredVelocity) dir = normalisedOrZero(q.prefVelocity);
    // A zero reference direction (agent at rest) would collapse every sample onto the base;
    // fall back to the x axis so the cone still spans the requested angle.
    if (dir.squaredNorm() == 0) dir = Vec2(1, 0);

    const double halfAngle = s.angle / 360.0 * kPi;
    Vec2 best = base;
    double bestCost = std::numeric_limits<double>::infinity();
    // Skip candidates that cannot win: every term's lower bound, weighted by a non-negative coeff
    // and summed in totalCost()'s order, is ≤ the cost (rounding is monotone).
    bool bounded = true;
    for (const Entry& e : components_) bounded = bounded && e.coeff >= 0;
    auto consider = [&](const Vec2& v) {
        if (bounded && bestCost < std::numeric_limits<double>::infinity()) {
            double bound = 0;
            for (const Entry& e : components_) bound += e.coeff * e.component->costLowerBound(v, q, ctx);
            if (bound >= bestCost) return;
        }
        const double c = totalCost(v, q, ctx);
        if (c < bestCost) {  // strict: the first of equal candidates wins (deterministic)
            bestCost = c;
            best = v;
        }
    };

    // The preferred velocity first, so that among equal costs it wins (strict < below).
    if (s.includePreferredAsSample) consider(q.prefVelocity);
    if (s.type == SamplingSpec::Type::Random) {
        Rng rng = ctx.rng(q, kStreamSampling);
        if (s.includeBaseAsSample) consider(base);
        for (int k = 0; k < s.randomSamples; ++k) {
            const double a = rng.uniform(-halfAngle, halfAngle);
            const double len = rng.uniform(0.0, radius);
            consider(base + rotated(dir, a) * len);
        }
        return best;
    }

    // Regular: rings of equal speed step × directions of equal angle step. A full circle does not
    // repeat its first direction at the end; a cone includes both edges.
    const int na = std::max(1, s.angleSamples);
    const int ns = std::max(1, s.speedSamples);
    const double dAngle = na == 1 ? 0.0 : 2 * halfAngle / (s.angle >= 360 ? na : na - 1);
    const int ringsOutside = s.includeBaseAsSample ? ns - 1 : ns;
    const double dLength = ringsOutside > 0 ? radius / ringsOutside : 0.0;
    if (s.includeBaseAsSample) consider(base);
    for (int ring = 1; ring <= ringsOutside; ++ring) {
        const double len = dLength * ring;
        for (int a = 0; a < na; ++a) consider(base + rotated(dir, -halfAngle + a * dAngle) * len);
    }
    return best;
}

Vec2 PolicyStep::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    if (components_.empty()) return {0, 0};
    if (spec_.method == OptimisationMethod::Gradient) {
        Vec2 g(0, 0);
        for (const Entry& e : components_) g += e.coeff * e.component->gradient(q.velocity, q, ctx);
        return -g;
    }
    Vec2 best;
    if (spec_.method == OptimisationMethod::Global && components_.size() == 1) {
        auto m = components_[0].component->globalMinimum(q, ctx);
        best = m ? *m : bestVelocitySampling(q, ctx, denseSampling());
    } else if (spec_.method == OptimisationMethod::Global) {
        best = bestVelocitySampling(q, ctx, denseSampling());
    } else {
        best = bestVelocitySampling(q, ctx, spec_.sampling);
    }
    // Relaxation towards the optimum; at least one step long so it never overshoots (UMANS).
    return (best - q.velocity) / std::max(spec_.relaxationTime, ctx.dt);
}

double PolicyStep::blendWeight(double value, double from, double to) {
    if (std::isnan(value) || from == to) return 0.0;
    return std::clamp((value - from) / (to - from), 0.0, 1.0);
}

double PolicyStep::weight(std::size_t i) const {
    if (!spec_.blend) return 1.0;
    if (blendField_ == nullptr || i >= blendField_->size()) return 0.0;
    return blendWeight((*blendField_)[i], spec_.blend->from, spec_.blend->to);
}

Policy::Policy(const PolicySpec& spec) : spec_(spec) {
    for (const StepSpec& s : spec.steps) steps_.emplace_back(s);
    for (PolicyStep& s : steps_) {
        if (!s.spec().blend) continue;
        const BlendSpec& b = *s.spec().blend;
        Component* source = findComponent(b.component);
        if (source == nullptr)
            throw std::runtime_error("policy " + std::to_string(spec.id) + ": the step blend follows component '" +
                                     b.component + "', which the policy does not have");
        const std::vector<double>* field = source->field(b.field);
        if (field == nullptr)
            throw std::runtime_error("policy " + std::to_string(spec.id) + ": component '" + b.component +
                                     "' has no per-agent field '" + b.field + "'");
        s.setBlendSource(field);
    }
}

Component* Policy::findComponent(const std::string& name) {
    for (PolicyStep& s : steps_)
        for (auto& e : s.components())
            if (e.name == name) return e.component.get();
    return nullptr;
}

}  // namespace ch
