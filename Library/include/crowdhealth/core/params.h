// CrowdHealth — parameter tables: one declaration per parameter drives the XML loader, the
// validation messages, `crowdhealth --list-policies` and the XML reference in docs/.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace ch {

enum class ParamType { Real, Integer, Bool, Choice };

/// One parameter of a component (or of a policy step): name as written in XML, unit, default,
/// allowed range and a one-line description.
struct ParamSpec {
    std::string name;
    std::string unit;         ///< SI unit ("m", "s", "m/s", "1/s", "-" for dimensionless …)
    double defaultValue = 0;  ///< for Choice: index into `choices`; for Bool: 0 or 1
    double min = -1e300;      ///< inclusive
    double max = 1e300;       ///< inclusive
    std::string description;
    ParamType type = ParamType::Real;
    std::vector<std::string> choices;  ///< allowed words for Choice parameters
    /// The range excludes `min` (resp. `max`) itself, e.g. a radius in (0, 10] m. Set these after
    /// a factory call for strictly positive quantities instead of inventing a tiny minimum.
    bool minExclusive = false;
    bool maxExclusive = false;

    static ParamSpec real(std::string name, std::string unit, double def, double min, double max,
                          std::string description);
    static ParamSpec integer(std::string name, double def, double min, double max, std::string description);
    static ParamSpec boolean(std::string name, bool def, std::string description);
    static ParamSpec choice(std::string name, std::vector<std::string> choices, int defaultIndex,
                            std::string description);

    /// "[0, 10] m" or "one of: a, b" — used in error messages and docs.
    std::string rangeText() const;
    /// True when v lies in [min, max], each end open where the spec says so (NaN: false).
    bool contains(double v) const {
        const bool lo = minExclusive ? v > min : v >= min;
        const bool hi = maxExclusive ? v < max : v <= max;
        return lo && hi;
    }
    /// The default written as it would appear in XML.
    std::string defaultText() const;
    /// Parses an XML attribute value; on failure returns false and sets `why`.
    bool parse(const std::string& text, double& value, std::string& why) const;
};

using ParamTable = std::vector<ParamSpec>;

/// Values of one component instance: every parameter of its table, defaults filled in.
class ParamSet {
public:
    ParamSet() = default;
    /// All defaults of `table`.
    explicit ParamSet(const ParamTable& table);

    void set(const std::string& name, double value) { values_[name] = value; }
    bool has(const std::string& name) const { return values_.count(name) != 0; }
    /// Value of a Real/Integer/Bool parameter (Choice: the index). Throws std::out_of_range if absent.
    double get(const std::string& name) const;
    bool flag(const std::string& name) const { return get(name) != 0.0; }
    /// The chosen word of a Choice parameter.
    std::string choice(const std::string& name) const;
    const std::map<std::string, double>& values() const { return values_; }

private:
    std::map<std::string, double> values_;
    std::map<std::string, std::vector<std::string>> choices_;
};

}  // namespace ch
