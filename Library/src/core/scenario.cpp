// CrowdHealth — ScenarioSpec helpers.
#include "crowdhealth/core/scenario.h"

#include <algorithm>
#include <cmath>

namespace ch {

int ScenarioSpec::fineStepsPerCoarse() const {
    // The loader guarantees deltaTime = n · deltaTimeFine (relative tolerance 1e-9); rounding
    // absorbs the representation error of decimal inputs such as 0.1 / 0.02.
    if (deltaTimeFine <= 0 || deltaTime <= 0) return 1;
    return std::max(1, static_cast<int>(std::lround(deltaTime / deltaTimeFine)));
}

std::optional<TrajectoryFormats> parseTrajectoryFormats(const std::string& text) {
    TrajectoryFormats f;
    std::size_t words = 0;
    bool none = false;
    std::size_t begin = 0;
    while (true) {
        const std::size_t comma = text.find(',', begin);
        std::string word = text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin);
        const auto first = word.find_first_not_of(" \t");
        word = first == std::string::npos ? "" : word.substr(first, word.find_last_not_of(" \t") - first + 1);
        ++words;
        if (word == "umans") f.umans = true;
        else if (word == "txt") f.txt = true;
        else if (word == "bin") f.bin = true;
        else if (word == "both") f.umans = f.txt = true;
        else if (word == "none") none = true;
        else return std::nullopt;  // also an empty word ("txt,", ",bin")
        if (comma == std::string::npos) break;
        begin = comma + 1;
    }
    if (none && words > 1) return std::nullopt;  // "none,txt" contradicts itself
    return f;
}

}  // namespace ch
