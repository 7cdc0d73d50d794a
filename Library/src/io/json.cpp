// CrowdHealth — JSON through nlohmann/json (see json.h).
#include "crowdhealth/io/json.h"

#include "crowdhealth/io/output.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace ch {

Json jsonNumber(double v, int digits) {
    if (!std::isfinite(v)) return nullptr;
    if (v == 0.0) return 0;  // also -0: the sign of a zero carries no information in a report
    constexpr double kExactIntegers = 9007199254740992.0;  // 2^53
    if (std::abs(v) < kExactIntegers && v == std::trunc(v)) return static_cast<std::int64_t>(v);
    // Round to `digits` significant digits (locale-independent text), then back to the double
    // nearest that text: the library writes the shortest text that reads back as this double,
    // which is then the rounded one.
    const std::string text = formatNumber(v, digits);
    double rounded = v;
    std::from_chars(text.data(), text.data() + text.size(), rounded);
    if (rounded == std::trunc(rounded) && std::abs(rounded) < kExactIntegers) return static_cast<std::int64_t>(rounded);
    return rounded;
}

std::string jsonText(const Json& value) {
    return value.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

Json readJsonFile(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw JsonError(path.string() + ": cannot read it");
    std::ostringstream text;
    text << in.rdbuf();
    try {
        return Json::parse(text.str());
    } catch (const Json::parse_error& e) {
        // e.what() is "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
        std::string message = e.what();
        const std::size_t at = message.find("] ");
        if (at != std::string::npos) message.erase(0, at + 2);
        throw JsonError(path.string() + ": not valid JSON: " + message);
    }
}

std::optional<double> jsonOptionalNumber(const Json& object, const std::string& key, const std::filesystem::path& file) {
    if (!object.is_object()) throw JsonError(file.string() + ": expected a JSON object around \"" + key + "\"");
    const auto it = object.find(key);
    if (it == object.end() || it->is_null()) return std::nullopt;
    if (!it->is_number())
        throw JsonError(file.string() + ": \"" + key + "\" should be a number or null, not " + it->dump());
    return it->get<double>();
}

}  // namespace ch
