// CrowdHealth — loading plugins (crowdhealth/core/plugins.h).
#include "crowdhealth/core/plugins.h"

#include "crowdhealth/core/registry.h"
#include "crowdhealth/plugin.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <mutex>
#include <set>

namespace ch {

namespace {

std::mutex& pluginMutex() {
    static std::mutex m;
    return m;
}

std::vector<std::string>& loaded() {
    static std::vector<std::string> list;
    return list;
}

std::string dlMessage() {
    const char* e = dlerror();
    return e != nullptr ? std::string(e) : std::string("unknown reason");
}

/// A plugin resolves the library's functions (base classes, the registry) in the global scope.
/// A program linked with the library exports them there already (the `crowdhealth` program is
/// linked with -rdynamic; libcrowdhealth.so is loaded globally by the programs linked to it). A
/// library opened with RTLD_LOCAL — the Python module, which holds its own copy of the library —
/// is promoted to the global scope here, once, so that its plugins find its registry.
void exportLibrarySymbols() {
    static const bool done = [] {
        Dl_info info{};
        if (dladdr(reinterpret_cast<void*>(&Registry::instance), &info) != 0 && info.dli_fname != nullptr) {
            // RTLD_NOLOAD: only changes the flags of the object already loaded (no-op for the program itself).
            if (void* self = dlopen(info.dli_fname, RTLD_LAZY | RTLD_NOLOAD | RTLD_GLOBAL)) (void)self;
            else (void)dlerror();
        }
        return true;
    }();
    (void)done;
}

}  // namespace

std::string findPlugin(const std::string& name, const std::string& base) {
    namespace fs = std::filesystem;
    const fs::path named(name);
    if (named.is_absolute()) return name;
    const fs::path here = base.empty() ? named : fs::path(base) / named;
    std::error_code ec;
    if (fs::exists(here, ec)) return here.string();
    if (const char* env = std::getenv("CROWDHEALTH_PLUGIN_PATH")) {
        const std::string list = env;
        std::size_t start = 0;
        while (start <= list.size()) {
            const std::size_t colon = std::min(list.find(':', start), list.size());
            const std::string dir = list.substr(start, colon - start);
            if (!dir.empty() && fs::exists(fs::path(dir) / named, ec)) return (fs::path(dir) / named).string();
            start = colon + 1;
        }
    }
    return here.string();
}

const char* pluginAbi() { return CROWDHEALTH_PLUGIN_ABI; }

std::vector<std::string> loadedPlugins() {
    const std::lock_guard<std::mutex> lock(pluginMutex());
    return loaded();
}

PluginLoad loadPlugin(const std::string& file) {
    namespace fs = std::filesystem;
    PluginLoad r;
    r.path = file;
    const std::lock_guard<std::mutex> lock(pluginMutex());
    try {
        std::error_code ec;
        if (!fs::exists(file, ec)) {
            r.error = "no such file";
            if (const char* env = std::getenv("CROWDHEALTH_PLUGIN_PATH"); env != nullptr && *env != 0)
                r.error += std::string(" (nor in CROWDHEALTH_PLUGIN_PATH=") + env + ")";
            return r;
        }
        if (fs::is_directory(file, ec)) {
            r.error = "is a folder, not a shared library";
            return r;
        }
        r.path = fs::canonical(file, ec).string();
        if (ec) r.path = fs::absolute(file).lexically_normal().string();
        for (const std::string& p : loaded())
            if (p == r.path) {
                r.ok = r.alreadyLoaded = true;
                return r;
            }
        exportLibrarySymbols();
        // A path with a slash: dlopen takes it as a file, never searching the library path.
        const std::string open = r.path.find('/') == std::string::npos ? "./" + r.path : r.path;
        (void)dlerror();
        void* handle = dlopen(open.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (handle == nullptr) {
            const std::string why = dlMessage();
            r.error = "cannot be loaded: " + why;
            if (why.find("undefined symbol") != std::string::npos)
                r.error += " (it needs a CrowdHealth function this program does not have: it was probably built "
                           "against another CrowdHealth version; rebuild it against this one, " +
                           std::string(CROWDHEALTH_VERSION_STRING) + ")";
            else if (why.find("invalid ELF header") != std::string::npos || why.find("file too short") != std::string::npos)
                r.error += " (not a shared library: a plugin is a .so built as in Examples/plugin/)";
            return r;
        }
        // From here on the library stays loaded even when it is refused: its static objects may
        // already be referenced, and unloading C++ code safely is not worth the risk.
        using AbiFn = const char* (*)();
        using RegisterFn = void (*)(void*);
        const auto abi = reinterpret_cast<AbiFn>(dlsym(handle, "crowdhealth_plugin_abi"));
        const auto reg = reinterpret_cast<RegisterFn>(dlsym(handle, "crowdhealth_plugin_register"));
        if (abi == nullptr || reg == nullptr) {
            r.error = std::string("has no entry point ") +
                      (abi == nullptr ? "crowdhealth_plugin_abi" : "crowdhealth_plugin_register") +
                      ": not a CrowdHealth plugin (a plugin ends with CROWDHEALTH_PLUGIN(function), "
                      "crowdhealth/plugin.h)";
            return r;
        }
        const std::string theirs = abi() != nullptr ? abi() : "";
        if (theirs != CROWDHEALTH_PLUGIN_ABI) {
            r.error = "was built against " + (theirs.empty() ? std::string("an unknown CrowdHealth") : "'" + theirs + "'") +
                      ", this program is '" + CROWDHEALTH_PLUGIN_ABI + "': rebuild the plugin against this CrowdHealth";
            return r;
        }
        PluginRegistrar registrar;
        try {
            reg(&registrar);
        } catch (const std::exception& e) {
            r.error = std::string("failed while registering its components: ") + e.what();
            return r;
        } catch (...) {
            r.error = "failed while registering its components (an exception that is not a std::exception)";
            return r;
        }
        std::vector<ComponentInfo>& infos = registrar.pending();
        if (infos.empty()) {
            r.error = "registers no component (its registration function adds none)";
            return r;
        }
        // Whole or nothing: every component must be valid before any is added.
        std::set<std::string> names;
        for (ComponentInfo& info : infos) {
            info.origin = r.path;
            if (const std::string why = Registry::instance().problem(info); !why.empty()) {
                r.error = why;
                return r;
            }
            if (!names.insert(info.name).second) {
                r.error = "registers the component '" + info.name + "' twice";
                return r;
            }
        }
        for (ComponentInfo& info : infos) {
            r.components.push_back(info.name);
            Registry::instance().add(std::move(info));
        }
        loaded().push_back(r.path);
        r.ok = true;
    } catch (const std::exception& e) {
        r.ok = false;
        r.error = e.what();
    }
    return r;
}

}  // namespace ch
