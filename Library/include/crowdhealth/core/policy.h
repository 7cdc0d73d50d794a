// CrowdHealth — policies: one or more steps, each an optimisation method over a weighted list
// of components on the coarse or fine time step (DESIGN §2).
#pragma once

#include "crowdhealth/core/component.h"
#include "crowdhealth/core/scenario.h"

#include <memory>
#include <vector>

namespace ch {

class PolicyStep {
public:
    /// Builds every component from the registry (throws RegistryError for an unknown name).
    explicit PolicyStep(const StepSpec& spec);

    const StepSpec& spec() const { return spec_; }
    StepTiming timing() const { return spec_.timing; }
    /// Largest `range` of its components (m): the radius of the neighbourhood gathered per agent.
    double interactionRange() const { return range_; }

    struct Entry {
        std::unique_ptr<Component> component;
        double coeff;
        std::string name;
    };
    std::vector<Entry>& components() { return components_; }
    const std::vector<Entry>& components() const { return components_; }

    void prepare(const StepContext& ctx);
    /// The acceleration (m/s²) this step asks for, before any clamp:
    ///  gradient: -Σ coeff·∇cost(v_current);
    ///  sampling/global: (v* - v)/max(τ, dt) where v* minimises Σ coeff·cost (UMANS).
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const;
    /// The minimising velocity by sampling with the given settings (exposed for tests).
    Vec2 bestVelocitySampling(const AgentQuery& q, const StepContext& ctx, const SamplingSpec& s) const;
    /// Total weighted cost of v.
    double totalCost(const Vec2& v, const AgentQuery& q, const StepContext& ctx) const;

    /// The settings UMANS uses to approximate a global optimum by dense sampling.
    static SamplingSpec denseSampling();

    /// Weight of this step for agent i (index = AgentStore index): 1 without a blend, otherwise
    /// blendWeight(f_i, from, to) with f the blend field (StepSpec::blend). An agent the field
    /// does not cover yet, or a NaN value, gets weight 0.
    double weight(std::size_t i) const;
    /// clamp((value − from)/(to − from), 0, 1); from ≠ to.
    static double blendWeight(double value, double from, double to);
    /// Connects the blend to the per-agent field it follows (done by Policy).
    void setBlendSource(const std::vector<double>* field) { blendField_ = field; }

private:
    StepSpec spec_;
    std::vector<Entry> components_;
    double range_ = 0;
    const std::vector<double>* blendField_ = nullptr;  ///< owned by a component of the same policy
};

class Policy {
public:
    /// Builds the steps and connects every step's blend to its field. Throws std::runtime_error
    /// when a blend names a component or field the policy does not have (the loader reports
    /// these first, with file and line).
    explicit Policy(const PolicySpec& spec);
    int id() const { return spec_.id; }
    const PolicySpec& spec() const { return spec_; }
    std::vector<PolicyStep>& steps() { return steps_; }
    const std::vector<PolicyStep>& steps() const { return steps_; }
    double contactForceScale() const { return spec_.contactForceScale; }
    /// Finds a component by registered name in any step (first match), or nullptr.
    Component* findComponent(const std::string& name);

private:
    PolicySpec spec_;
    std::vector<PolicyStep> steps_;
};

}  // namespace ch
