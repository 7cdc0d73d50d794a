// crowdhealth — numbers and lists in command-line arguments and in the program's text files
// (sweep, calibrate, the command line, the Python module): one definition of each.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace chcli {

/// A whole text as a finite number ("1e3" yes; "", "2abc", "inf", "nan" no). Numbers are taken as
/// strings and checked here: Boost's lexical_cast would accept "2abc" in some versions.
inline bool parseDouble(const std::string& text, double& value) {
    const char* end = text.data() + text.size();
    const auto res = std::from_chars(text.data(), end, value);
    return !text.empty() && res.ec == std::errc() && res.ptr == end && std::isfinite(value);
}

/// A whole text as a whole number ≥ 0 ("-1" is refused, not wrapped to 2^64 − 1).
inline bool parseUnsigned(const std::string& text, std::uint64_t& value) {
    const char* end = text.data() + text.size();
    const auto res = std::from_chars(text.data(), end, value);
    return !text.empty() && res.ec == std::errc() && res.ptr == end;
}

/// Every digit (17 significant): a value that must read back exactly (job texts, records).
inline std::string exactNumber(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

/// 10 significant digits, as the program's CSV summaries (summary.csv, sweep.csv,
/// calibration.csv); "" for a value that is not finite.
inline std::string csvCell(double v) {
    if (!std::isfinite(v)) return "";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

/// `s` cut at every `sep` (empty pieces kept: "a,,b" → a, "", b; "" → one empty piece).
inline std::vector<std::string> splitOn(const std::string& s, char sep) {
    std::vector<std::string> out(1);
    for (const char c : s) {
        if (c == sep) out.emplace_back();
        else out.back() += c;
    }
    return out;
}

}  // namespace chcli
