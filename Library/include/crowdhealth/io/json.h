// CrowdHealth — JSON through one library (nlohmann/json, Debian's nlohmann-json3-dev).
//
// Every JSON file the program writes (summary.json, render.json) is built as a ch::Json value and
// serialised by the library, and every JSON file it reads is parsed by it: no JSON text is put
// together or taken apart by hand. ch::Json keeps the keys in insertion order, so the files list
// them in the documented order.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

namespace ch {

/// A JSON value whose objects keep their keys in insertion order.
using Json = nlohmann::ordered_json;

/// A JSON file that cannot be read or is not valid JSON; what() names the file and the problem.
class JsonError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// The JSON value of a number, readable: `null` when v is NaN or infinite (JSON has neither);
/// an integer when v is a whole number of magnitude below 2^53 (so 300 stays "300", not "300.0");
/// otherwise v rounded to `digits` significant digits, so 92·0.1 = 9.200000000000001 is written
/// 9.2. Ten digits lose nothing measurable.
Json jsonNumber(double v, int digits = 10);

/// The text of a JSON document as written to a file: the library's serialisation with an indent
/// of 2 and a final newline. Strings are escaped by the library (invalid UTF-8 is replaced by
/// U+FFFD rather than producing an invalid file).
std::string jsonText(const Json& value);

/// Parses the JSON file at `path`. Throws JsonError "<path>: cannot read it" or
/// "<path>: not valid JSON: <the parser's message with line and column>".
Json readJsonFile(const std::filesystem::path& path);

/// The number at `key` of `object`: nullopt when absent or null. Throws JsonError naming `file`
/// and the key when the value is there but not a number.
std::optional<double> jsonOptionalNumber(const Json& object, const std::string& key,
                                         const std::filesystem::path& file);

}  // namespace ch
