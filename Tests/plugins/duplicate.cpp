// A plugin that registers a name a built-in component already has: the loader must refuse it and
// register nothing (not even its other, valid component).
#include <crowdhealth/plugin.h>

namespace {

class Nothing : public ch::ForceComponent {
public:
    explicit Nothing(const ch::ParamSet& p) { bind(p, "range", range_); }
    ch::Vec2 acceleration(const ch::AgentQuery&, const ch::StepContext&) const override { return {0, 0}; }
};

ch::ComponentInfo info(const char* name) {
    ch::ComponentInfo i;
    i.name = name;
    i.kind = ch::ComponentKind::Force;
    i.summary = "does nothing";
    i.create = [](const ch::ParamSet& p) { return std::make_unique<Nothing>(p); };
    return i;
}

void add(ch::PluginRegistrar& r) {
    r.add(info("ValidButRefusedWithItsPlugin"));
    r.add(info("GoalReachingForce"));
}

}  // namespace

CROWDHEALTH_PLUGIN(add)
