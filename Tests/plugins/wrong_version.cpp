// A plugin that says it was built against another CrowdHealth: the loader must refuse it.
#include <crowdhealth/plugin.h>

extern "C" __attribute__((visibility("default"))) const char* crowdhealth_plugin_abi() {
    return "CrowdHealth 0.0.1, plugin interface 1, libstdc++ cxx11 ABI";
}
extern "C" __attribute__((visibility("default"))) void crowdhealth_plugin_register(void*) {}
