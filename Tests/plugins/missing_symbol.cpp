// A plugin that calls a CrowdHealth function the program does not have (as one built against
// another version would): the loader must refuse it with the reason.
#include <crowdhealth/plugin.h>

namespace ch {
double functionFromAnotherVersion(double);
}

namespace {
void add(ch::PluginRegistrar&) { (void)ch::functionFromAnotherVersion(1.0); }
}  // namespace

CROWDHEALTH_PLUGIN(add)
