// CrowdHealth — diagnostics: every problem found in the input, with file and line.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace ch {

/// The name of an input file, held once and shared by every copy: a location is copied into
/// every agent's spec (a million of them for an <AgentGrid> of a million), and a path longer
/// than std::string's inline buffer (15 characters) cost an allocation per copy — 213 MiB more
/// peak memory for the 1M-agent scene under a long path. Names are interned: equal names share
/// one string, which lives until the program ends. Reads as a const std::string&.
class FileName {
public:
    FileName() = default;
    FileName(const std::string& name);  // NOLINT(google-explicit-constructor): assigned from paths everywhere
    FileName(const char* name) : FileName(std::string(name)) {}  // NOLINT(google-explicit-constructor)

    const std::string& str() const { return name_ != nullptr ? *name_ : none(); }
    operator const std::string&() const { return str(); }  // NOLINT(google-explicit-constructor)
    bool empty() const { return str().empty(); }
    const char* c_str() const { return str().c_str(); }

    friend bool operator==(const FileName& a, const FileName& b) { return a.name_ == b.name_; }  // interned
    friend bool operator==(const FileName& a, const std::string& b) { return a.str() == b; }
    friend bool operator==(const FileName& a, const char* b) { return a.str() == b; }
    friend std::string operator+(const FileName& a, const std::string& b) { return a.str() + b; }
    friend std::string operator+(const std::string& a, const FileName& b) { return a + b.str(); }
    friend std::string operator+(const FileName& a, const char* b) { return a.str() + b; }
    friend std::string operator+(const char* a, const FileName& b) { return a + b.str(); }
    friend std::string operator+(const FileName& a, char b) { return a.str() + b; }
    friend std::ostream& operator<<(std::ostream& out, const FileName& f);

private:
    static const std::string& none();
    const std::string* name_ = nullptr;  ///< the interned name (null: no file)
};

/// Where something came from in the input files (line 0 = unknown / whole file).
struct SourceLoc {
    FileName file;
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
