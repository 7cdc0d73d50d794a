// An example CrowdHealth plugin: one force, `DistancingForce`, in a shared library of its own,
// built without touching CrowdHealth's sources (docs/adding-a-policy.md, "As a plugin").
//
// The force keeps pedestrians apart when their centres come closer than `distance` (say the
// 1.5 m of a distancing rule): a linear spring on the intrusion,
//     a_i = strength · Σ_j (1 − d_ij / distance) · (x_i − x_j) / d_ij   over neighbours with d_ij < distance,
// zero beyond `distance`, at most `strength` per neighbour. It is an illustration of the plugin
// interface (a desire to keep a distance, in the spirit of the repulsive term of the social
// force model, Helbing & Molnár 1995), not a calibrated model.
#include <crowdhealth/plugin.h>

#include <cmath>

namespace distancing {

class DistancingForce : public ch::ForceComponent {
public:
    explicit DistancingForce(const ch::ParamSet& params) {
        // bind(): read the value and let <Ramp>, sweeps, Python and C change it while running.
        bind(params, "range", range_);
        bind(params, "distance", distance_);
        bind(params, "strength", strength_);
    }

    static ch::ComponentInfo Info() {
        ch::ComponentInfo info;
        info.name = "DistancingForce";
        info.kind = ch::ComponentKind::Force;
        info.defaultRange = 2.0;  // m: must cover `distance` (the loader checks the values, not this)
        info.summary = "example plugin: pushes pedestrians apart whose centres are closer than `distance`";
        info.reference = "Examples/plugin (an illustration of the plugin interface, not a calibrated model)";
        info.params = {
            ch::ParamSpec::real("distance", "m", 1.5, 0.0, 10.0, "centre distance kept from others"),
            ch::ParamSpec::real("strength", "m/s²", 2.0, 0.0, 100.0, "acceleration per neighbour at zero distance"),
        };
        info.create = [](const ch::ParamSet& p) { return std::make_unique<DistancingForce>(p); };
        return info;
    }

    ch::Vec2 acceleration(const ch::AgentQuery& q, const ch::StepContext& ctx) const override {
        ch::Vec2 a(0, 0);
        const double reach = std::min(distance_, range_);
        // offset = x_j − x_i; neighbours come in a fixed order, so the sum is the same on any thread count.
        ctx.forEachNeighbour(static_cast<std::size_t>(q.i), reach, [&](int, const ch::Vec2& offset, double d2) {
            if (d2 <= 0) return;  // on top of each other: no direction to push in
            const double d = std::sqrt(d2);
            a -= strength_ * (1.0 - d / distance_) * offset / d;
        });
        return a;
    }

private:
    double distance_ = 1.5;
    double strength_ = 2.0;
};

void addComponents(ch::PluginRegistrar& registrar) { registrar.add(DistancingForce::Info()); }

}  // namespace distancing

// The plugin's entry points: its ABI string (checked by the loader) and the registration function.
CROWDHEALTH_PLUGIN(distancing::addComponents)
