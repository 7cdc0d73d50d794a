// CrowdHealth — the component registry.
#include "crowdhealth/core/registry.h"

#include <algorithm>
#include <mutex>

namespace ch {

Registry& Registry::instance() {
    // Function-local static: safe to use from other translation units' static initialisers.
    static Registry registry;
    return registry;
}

std::string Registry::problem(const ComponentInfo& info) const {
    if (info.name.empty()) return "cannot register a component without a name";
    if (!info.create) return "component '" + info.name + "' has no factory";
    {
        const std::shared_lock<std::shared_mutex> lock(mutex_);
        if (const ComponentInfo* taken = findLocked(info.name))
            return "component '" + info.name + "' is registered twice" +
                   (taken->origin.empty() ? std::string(" (the name is a built-in component's)")
                                          : " (the name is taken by the plugin " + taken->origin + ")");
    }
    for (const ParamSpec& p : info.params)
        for (const ParamSpec& c : commonParams())
            if (p.name == c.name) return "component '" + info.name + "' redeclares the common parameter '" + p.name + "'";
    return "";
}

bool Registry::add(ComponentInfo info) {
    if (const std::string why = problem(info); !why.empty()) throw RegistryError(why);
    const std::unique_lock<std::shared_mutex> lock(mutex_);
    if (findLocked(info.name) != nullptr) throw RegistryError("component '" + info.name + "' is registered twice");
    entries_.push_back(std::move(info));
    return true;
}

const ComponentInfo* Registry::findLocked(const std::string& name) const {
    for (const ComponentInfo& e : entries_)
        if (e.name == name) return &e;
    return nullptr;
}

const ComponentInfo* Registry::find(const std::string& name) const {
    const std::shared_lock<std::shared_mutex> lock(mutex_);
    return findLocked(name);
}

std::vector<std::string> Registry::names() const {
    const std::shared_lock<std::shared_mutex> lock(mutex_);
    std::vector<std::string> out;
    for (const ComponentInfo& e : entries_) out.push_back(e.name);
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<const ComponentInfo*> Registry::all() const {
    const std::shared_lock<std::shared_mutex> lock(mutex_);
    std::vector<const ComponentInfo*> out;
    for (const ComponentInfo& e : entries_) out.push_back(&e);
    std::sort(out.begin(), out.end(), [](auto* a, auto* b) { return a->name < b->name; });
    return out;
}

const ParamTable& Registry::commonParams() {
    static const ParamTable table = {
        ParamSpec::real("coeff", "-", 1.0, -1e6, 1e6, "weight of this component in its step's sum (UMANS coeff)"),
        ParamSpec::real("range", "m", 5.0, 0.0, 1e4,
                        "interaction range: neighbours and walls farther away are ignored"),
    };
    return table;
}

ParamTable Registry::fullTable(const ComponentInfo& info) {
    ParamTable t = commonParams();
    for (ParamSpec& p : t)
        if (p.name == "range") p.defaultValue = info.defaultRange;
    t.insert(t.end(), info.params.begin(), info.params.end());
    return t;
}

std::unique_ptr<Component> createComponent(const std::string& name, const ParamSet& params) {
    const ComponentInfo* info = Registry::instance().find(name);
    if (info == nullptr) throw RegistryError("unknown component '" + name + "'");
    // Fill any missing values with defaults so components can rely on every name being present.
    ParamSet full(Registry::fullTable(*info));
    for (const auto& [k, v] : params.values()) full.set(k, v);
    return info->create(full);
}

std::string fixedForTheRun(const std::string& component, const std::string& parameter) {
    if (component == "CrowdHealth")
        return parameter == "fallenRadius"
                   ? "CrowdHealth.fallenRadius is fixed for the run (the neighbour range is set from it when the run starts)"
                   : std::string();
    if (parameter == "coeff")
        return component + ".coeff is fixed for the run (the policy step reads a component's weight when the run starts)";
    if (parameter == "range")
        return component + ".range is fixed for the run (the neighbour lists are sized from it when the run starts)";
    return {};
}

}  // namespace ch
