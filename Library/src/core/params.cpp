// CrowdHealth — parameter tables: factories, strict parsing and range texts.
#include "crowdhealth/core/params.h"

#include "crowdhealth/io/diagnostics.h"

#include <charconv>
#include <cmath>
#include <stdexcept>
#include <system_error>

namespace ch {

namespace {

/// Bounds at or beyond this magnitude mean "unbounded" (the ParamSpec defaults are ±1e300).
constexpr double kUnbounded = 1e300;

/// Shortest text that reads back to the same double; whole numbers without an exponent.
std::string formatNumber(double v) {
    if (std::isnan(v)) return "nan";
    if (v >= kUnbounded) return "inf";
    if (v <= -kUnbounded) return "-inf";
    if (v == std::floor(v) && std::fabs(v) < 1e15) {
        char buf[32];
        auto res = std::to_chars(buf, buf + sizeof buf, static_cast<long long>(v));
        return std::string(buf, res.ptr);
    }
    char buf[64];
    auto res = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, res.ptr);
}

std::string trim(const std::string& s) {
    const char* ws = " \t\r\n";
    const auto first = s.find_first_not_of(ws);
    if (first == std::string::npos) return "";
    const auto last = s.find_last_not_of(ws);
    return s.substr(first, last - first + 1);
}

std::string quoted(const std::string& s) { return "'" + s + "'"; }

/// Strict real: the whole (trimmed) text must be one decimal number; NaN and infinities refused.
bool parseReal(const std::string& t, double& out, std::string& why) {
    if (t.empty()) {
        why = "an empty value is not a number";
        return false;
    }
    const char* begin = t.data();
    const char* end = t.data() + t.size();
    if (*begin == '+') ++begin;  // strtod (and so UMANS) accepts a leading '+'
    double v = 0;
    auto res = std::from_chars(begin, end, v);
    if (res.ptr != end || begin == end || (res.ec != std::errc() && res.ec != std::errc::result_out_of_range)) {
        why = quoted(t) + " is not a number";
        return false;
    }
    if (res.ec == std::errc::result_out_of_range || !std::isfinite(v)) {
        why = quoted(t) + " is not a finite number";
        return false;
    }
    out = v;
    return true;
}

/// Strict integer: optional sign and digits only ("3.0" and "1e3" are refused for counts).
bool parseInteger(const std::string& t, double& out, std::string& why) {
    if (t.empty()) {
        why = "an empty value is not a whole number";
        return false;
    }
    const char* begin = t.data();
    const char* end = t.data() + t.size();
    if (*begin == '+') ++begin;
    long long v = 0;
    auto res = std::from_chars(begin, end, v);
    if (res.ptr != end || begin == end || res.ec != std::errc()) {
        double ignoredValue = 0;
        std::string ignoredWhy;
        if (res.ec == std::errc::result_out_of_range)
            why = quoted(t) + " is too large";
        else if (parseReal(t, ignoredValue, ignoredWhy))
            why = quoted(t) + " is not a whole number";
        else
            why = quoted(t) + " is not a number";
        return false;
    }
    out = static_cast<double>(v);
    return true;
}

}  // namespace

ParamSpec ParamSpec::real(std::string name, std::string unit, double def, double min, double max,
                          std::string description) {
    ParamSpec p;
    p.name = std::move(name);
    p.unit = std::move(unit);
    p.defaultValue = def;
    p.min = min;
    p.max = max;
    p.description = std::move(description);
    p.type = ParamType::Real;
    return p;
}

ParamSpec ParamSpec::integer(std::string name, double def, double min, double max, std::string description) {
    ParamSpec p = real(std::move(name), "-", def, min, max, std::move(description));
    p.type = ParamType::Integer;
    return p;
}

ParamSpec ParamSpec::boolean(std::string name, bool def, std::string description) {
    ParamSpec p = real(std::move(name), "-", def ? 1.0 : 0.0, 0.0, 1.0, std::move(description));
    p.type = ParamType::Bool;
    return p;
}

ParamSpec ParamSpec::choice(std::string name, std::vector<std::string> choices, int defaultIndex,
                            std::string description) {
    const double last = choices.empty() ? 0.0 : static_cast<double>(choices.size() - 1);
    ParamSpec p = real(std::move(name), "-", defaultIndex, 0.0, last, std::move(description));
    p.type = ParamType::Choice;
    p.choices = std::move(choices);
    return p;
}

std::string ParamSpec::rangeText() const {
    switch (type) {
        case ParamType::Bool:
            return "true or false";
        case ParamType::Choice: {
            std::string out = "one of: ";
            for (std::size_t i = 0; i < choices.size(); ++i) out += (i ? ", " : "") + choices[i];
            return out;
        }
        case ParamType::Real:
        case ParamType::Integer:
            break;
    }
    // An infinite bound is never attained, so it is written with an open bracket.
    const bool openLow = minExclusive || min <= -kUnbounded;
    const bool openHigh = maxExclusive || max >= kUnbounded;
    std::string out(1, openLow ? '(' : '[');
    out += formatNumber(min);
    out += ", ";
    out += formatNumber(max);
    out += openHigh ? ')' : ']';
    if (!unit.empty() && unit != "-") {
        out += ' ';
        out += unit;
    }
    return out;
}

std::string ParamSpec::defaultText() const {
    switch (type) {
        case ParamType::Bool:
            return defaultValue != 0.0 ? "true" : "false";
        case ParamType::Choice: {
            const auto i = static_cast<std::size_t>(defaultValue);
            return i < choices.size() ? choices[i] : "";
        }
        case ParamType::Real:
        case ParamType::Integer:
            break;
    }
    return formatNumber(defaultValue);
}

bool ParamSpec::parse(const std::string& text, double& value, std::string& why) const {
    const std::string t = trim(text);
    switch (type) {
        case ParamType::Bool: {
            if (equalsIgnoreCase(t, "true") || t == "1") {
                value = 1.0;
                return true;
            }
            if (equalsIgnoreCase(t, "false") || t == "0") {
                value = 0.0;
                return true;
            }
            why = quoted(t) + " is not a boolean (true, false, 1 or 0)";
            return false;
        }
        case ParamType::Choice: {
            // Case-insensitive: "Regular" cannot mean anything but "regular".
            for (std::size_t i = 0; i < choices.size(); ++i)
                if (equalsIgnoreCase(t, choices[i])) {
                    value = static_cast<double>(i);
                    return true;
                }
            why = quoted(t) + " is not " + rangeText();
            const std::string hint = closestMatch(t, choices);
            if (!hint.empty()) why += " (did you mean '" + hint + "'?)";
            return false;
        }
        case ParamType::Real:
        case ParamType::Integer:
            break;
    }
    double v = 0;
    if (!(type == ParamType::Integer ? parseInteger(t, v, why) : parseReal(t, v, why))) return false;
    const bool belowMin = min > -kUnbounded && (minExclusive ? v <= min : v < min);
    const bool aboveMax = max < kUnbounded && (maxExclusive ? v >= max : v > max);
    if (belowMin || aboveMax) {
        why = t + " is not in " + rangeText();
        return false;
    }
    value = v;
    return true;
}

ParamSet::ParamSet(const ParamTable& table) {
    for (const ParamSpec& p : table) {
        values_[p.name] = p.defaultValue;
        if (p.type == ParamType::Choice) choices_[p.name] = p.choices;
    }
}

double ParamSet::get(const std::string& name) const {
    auto it = values_.find(name);
    if (it == values_.end()) throw std::out_of_range("parameter '" + name + "' is not set");
    return it->second;
}

std::string ParamSet::choice(const std::string& name) const {
    auto c = choices_.find(name);
    if (c == choices_.end()) throw std::out_of_range("parameter '" + name + "' is not a choice");
    const double index = get(name);
    if (index < 0 || index >= static_cast<double>(c->second.size()))
        throw std::out_of_range("parameter '" + name + "' holds no valid choice");
    return c->second[static_cast<std::size_t>(index)];
}

}  // namespace ch
