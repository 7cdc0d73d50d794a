// CrowdHealth tests — scenario files written by a test into a folder of its own and loaded as the
// program loads them (diagnostics kept as text).
#pragma once

#include "crowdhealth/io/diagnostics.h"
#include "crowdhealth/io/xml.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

namespace ch::test {

/// This test program's own folder under the system's temporary folder (removed at exit).
inline const std::filesystem::path& scratch() {
    namespace fs = std::filesystem;
    static const fs::path dir = [] {
        std::string templ = (fs::temp_directory_path() / "ch-test-XXXXXX").string();
        if (mkdtemp(templ.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
        return fs::path(templ);
    }();
    static const struct Cleanup {
        ~Cleanup() {
            std::error_code ec;
            fs::remove_all(dir, ec);
        }
    } cleanup;
    return dir;
}

struct Loaded {
    std::optional<ScenarioSpec> spec;
    std::string messages;  ///< every diagnostic, one per line
    std::string path;
};

/// Writes `xml` to scratch()/name and loads it.
inline Loaded load(const std::string& name, const std::string& xml) {
    Loaded out;
    out.path = (scratch() / name).string();
    std::ofstream(out.path, std::ios::binary) << xml;
    Diagnostics d;
    out.spec = loadScenario(out.path, d, {});
    std::ostringstream m;
    d.print(m);
    out.messages = m.str();
    return out;
}

}  // namespace ch::test
