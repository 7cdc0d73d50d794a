// CrowdHealth — diagnostics: every problem found in the input, with file and line.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace ch {

/// Where something came from in the input files (line 0 = unknown / whole file).
struct SourceLoc {
    std::string file;
    int line = 0;
};

enum class Severity { Warning, Error };

struct Diagnostic {
    Severity severity = Severity::Error;
    SourceLoc where;
    std::string message;
    /// "path:line: error: message" (or "warning:"), the format compilers use so editors can jump to it.
    std::string format() const;
};

/// Collects every diagnostic of a load so the user sees all problems at once.
class Diagnostics {
public:
    void error(const SourceLoc& where, std::string message);
    void warning(const SourceLoc& where, std::string message);
    bool hasErrors() const { return errorCount_ > 0; }
    int errorCount() const { return errorCount_; }
    const std::vector<Diagnostic>& all() const { return items_; }
    /// Prints every diagnostic, one per line, in the order found.
    void print(std::ostream& out) const;

private:
    std::vector<Diagnostic> items_;
    int errorCount_ = 0;
};

/// The candidate closest to `word` by edit distance (case-insensitive), or "" when none is close.
std::string closestMatch(const std::string& word, const std::vector<std::string>& candidates);

/// Case-insensitive ASCII comparison.
bool equalsIgnoreCase(const std::string& a, const std::string& b);

}  // namespace ch
