// CrowdHealth — writing a plugin: cost functions and forces in a shared library of your own,
// loaded at run time by `<Plugin file="…"/>` in a scenario or `crowdhealth --plugin FILE`, without
// rebuilding CrowdHealth (docs/adding-a-policy.md, "As a plugin"; Examples/plugin/).
//
// A plugin is a C++ shared library (a CMake MODULE library) that
//  * includes this header, defines its components as the built-in ones do (a subclass of
//    ch::Component or ch::ForceComponent, and a `static ch::ComponentInfo Info()`), and
//  * ends with CROWDHEALTH_PLUGIN(function), where `function(ch::PluginRegistrar&)` adds them.
// It does not link the CrowdHealth library: the program (or libcrowdhealth.so, or the Python
// module) that loads it provides the library's functions, so there is one registry and one copy of
// every base class. Components then appear in `crowdhealth --list-policies` and their parameters
// are checked by the loader like built-in ones.
//
// A plugin must be built against the same CrowdHealth version as the program that loads it, with
// the same C++ standard library ABI: the loader compares CROWDHEALTH_PLUGIN_ABI below and refuses
// a plugin built against another one (rebuild it).
#pragma once

#include "crowdhealth/core/registry.h"
#include "crowdhealth/version.h"

#include <string>
#include <vector>

/// Bumped whenever the component interface (component.h, registry.h, params.h, the step's data)
/// changes in a way that breaks compiled plugins within one CrowdHealth version.
#define CROWDHEALTH_PLUGIN_INTERFACE 3  // 2: Component::readsStepLists, 3: Component::readsQueryAgents (new virtuals)

#define CROWDHEALTH_PLUGIN_STR_INNER(x) #x
#define CROWDHEALTH_PLUGIN_STR(x) CROWDHEALTH_PLUGIN_STR_INNER(x)
#if defined(_GLIBCXX_USE_CXX11_ABI) && _GLIBCXX_USE_CXX11_ABI
#define CROWDHEALTH_PLUGIN_STDLIB "libstdc++ cxx11 ABI"
#else
#define CROWDHEALTH_PLUGIN_STDLIB "libstdc++ old ABI"
#endif
/// What a plugin was built against; the loader accepts only its own string.
#define CROWDHEALTH_PLUGIN_ABI                                                                  \
    "CrowdHealth " CROWDHEALTH_VERSION_STRING ", plugin interface " CROWDHEALTH_PLUGIN_STR( \
        CROWDHEALTH_PLUGIN_INTERFACE) ", " CROWDHEALTH_PLUGIN_STDLIB

namespace ch {

/// What a plugin's registration function gets: add() each component. Nothing reaches the registry
/// unless every component is valid and its name free, so a plugin is loaded whole or not at all.
class PluginRegistrar {
public:
    void add(ComponentInfo info) { pending_.push_back(std::move(info)); }
    /// The components added so far (read by the loader).
    std::vector<ComponentInfo>& pending() { return pending_; }

private:
    std::vector<ComponentInfo> pending_;
};

}  // namespace ch

/// The entry points every plugin defines, once, in one of its source files:
///   void addMyComponents(ch::PluginRegistrar& r) { r.add(MyForce::Info()); }
///   CROWDHEALTH_PLUGIN(addMyComponents)
#define CROWDHEALTH_PLUGIN(registerFunction)                                                          \
    extern "C" __attribute__((visibility("default"))) const char* crowdhealth_plugin_abi() {          \
        return CROWDHEALTH_PLUGIN_ABI;                                                                \
    }                                                                                                 \
    extern "C" __attribute__((visibility("default"))) void crowdhealth_plugin_register(void* registrar) { \
        registerFunction(*static_cast<::ch::PluginRegistrar*>(registrar));                            \
    }
