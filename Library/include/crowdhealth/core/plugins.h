// CrowdHealth — loading plugins (the host's side; plugin authors read crowdhealth/plugin.h).
#pragma once

#include <string>
#include <vector>

namespace ch {

struct PluginLoad {
    bool ok = false;
    std::string path;                     ///< the file, as a canonical path when it exists
    std::string error;                    ///< why it could not be loaded (not ok)
    std::vector<std::string> components;  ///< the names it registered (empty when loaded before)
    bool alreadyLoaded = false;           ///< the same file was loaded earlier in this process
};

/// Loads the plugin `file` (a shared library, see crowdhealth/plugin.h) and adds its components
/// to Registry::instance(). A file loaded before is not loaded again (ok, alreadyLoaded). Fails,
/// with a reason and nothing registered, when the file is missing or is not a shared library,
/// lacks the entry points, was built against another CrowdHealth (CROWDHEALTH_PLUGIN_ABI), needs
/// functions this program lacks, or registers a name already taken. Thread-safe; never throws.
/// Plugins stay loaded until the process ends.
PluginLoad loadPlugin(const std::string& file);

/// Where the plugin `name` is, when named from folder `base` (the folder of the XML file that names
/// it; "" for the working folder): `name` itself when absolute; else base/name when that exists;
/// else DIR/name for the first DIR of the environment variable CROWDHEALTH_PLUGIN_PATH
/// (colon-separated) where it exists; else base/name (then reported missing by loadPlugin).
std::string findPlugin(const std::string& name, const std::string& base);

/// The plugins loaded so far (canonical paths, in loading order).
std::vector<std::string> loadedPlugins();

/// The string a plugin must have been built against (CROWDHEALTH_PLUGIN_ABI of this library).
const char* pluginAbi();

}  // namespace ch
