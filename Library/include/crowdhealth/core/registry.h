// CrowdHealth — the registry: name → {factory, parameter table} for every cost function and
// force. Components register themselves next to their class with CH_REGISTER_COMPONENT, so adding
// a model is adding one .h/.cpp pair in Policies/.
#pragma once

#include "crowdhealth/core/component.h"
#include "crowdhealth/core/params.h"

#include <deque>
#include <functional>
#include <memory>
#include <shared_mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace ch {

struct ComponentInfo {
    std::string name;         ///< as written in XML: <costfunction name="…"/>
    ComponentKind kind = ComponentKind::CostFunction;
    std::string summary;      ///< one line: what it does
    std::string reference;    ///< the paper it implements
    ParamTable params;        ///< its own parameters (the common `coeff` and `range` are added)
    /// Default of the common `range` parameter (m): how far this component looks. 0 for
    /// components that need no neighbourhood (the step's query then only covers contact reach).
    double defaultRange = 5.0;
    /// True for components that model body contact themselves (ContactForces). A policy with one
    /// in any step gets no implicit UMANS post-step contact (PolicySpec::contactForceScale is 0
    /// unless the file sets ContactForceScale, which is then warned about): contact is applied once.
    bool modelsContact = false;
    std::function<std::unique_ptr<Component>(const ParamSet&)> create;
    /// Where it comes from: empty for a built-in component, else the plugin file (set by the loader).
    std::string origin;
};

class RegistryError : public std::logic_error {
public:
    using std::logic_error::logic_error;
};

class Registry {
public:
    static Registry& instance();

    /// Adds a component. Throws RegistryError when the name is already taken or the info is
    /// incomplete (problem() says why). Returns true (so it can initialise a static).
    bool add(ComponentInfo info);
    /// Why `info` cannot be added ("" when it can): no name, no factory, a name already taken, or
    /// a parameter that redeclares a common one.
    std::string problem(const ComponentInfo& info) const;
    const ComponentInfo* find(const std::string& name) const;
    /// Registered names, sorted.
    std::vector<std::string> names() const;
    /// Every entry, sorted by name.
    std::vector<const ComponentInfo*> all() const;

    /// Parameters every component accepts: `coeff` (weight) and `range` (m).
    static const ParamTable& commonParams();
    /// commonParams() followed by the component's own table.
    static ParamTable fullTable(const ComponentInfo& info);

private:
    const ComponentInfo* findLocked(const std::string& name) const;
    // A deque: a plugin loaded while simulations run adds entries without moving the ones those
    // simulations point to. The mutex lets a plugin be loaded while other threads load scenarios.
    std::deque<ComponentInfo> entries_;
    mutable std::shared_mutex mutex_;
};

/// Builds a component from its spec values (throws RegistryError for an unknown name).
std::unique_ptr<Component> createComponent(const std::string& name, const ParamSet& params);

/// Why `component`.`parameter` cannot change during a run (a <Ramp>, a sweep's --vary,
/// set_parameter from Python or C), or "" when it can. Fixed for the run: `coeff` (the weight is
/// held by the policy step, which reads it when the run starts), `range` (it sizes the neighbour
/// lists when the run starts) and CrowdHealth's `fallenRadius` (likewise).
std::string fixedForTheRun(const std::string& component, const std::string& parameter);

}  // namespace ch

#define CH_CONCAT_INNER(a, b) a##b
#define CH_CONCAT(a, b) CH_CONCAT_INNER(a, b)
/// Registers `Class` (which provides `static ComponentInfo Info();`) at static-initialisation time.
#define CH_REGISTER_COMPONENT(Class) \
    static const bool CH_CONCAT(chRegistered_, Class) = ::ch::Registry::instance().add(Class::Info())
