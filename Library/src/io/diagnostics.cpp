// CrowdHealth — diagnostics: formatting, collection and "did you mean" suggestions.
#include "crowdhealth/io/diagnostics.h"

#include <algorithm>
#include <cctype>
#include <mutex>
#include <ostream>
#include <unordered_set>

namespace ch {

FileName::FileName(const std::string& name) {
    if (name.empty()) return;
    // The pool of every name seen: a few per run (the scenario, its included files, command-line
    // sources). Never freed, not even at exit, so the pointers stay valid however locations are
    // copied, static ones included; the elements of an unordered_set never move.
    static std::mutex mutex;
    static auto* const pool = new std::unordered_set<std::string>;
    const std::lock_guard<std::mutex> lock(mutex);
    name_ = &*pool->insert(name).first;
}

const std::string& FileName::none() {
    static const std::string empty;
    return empty;
}

std::ostream& operator<<(std::ostream& out, const FileName& f) { return out << f.str(); }

std::string Diagnostic::format() const {
    // Compiler style so editors and CI logs can jump straight to the line.
    std::string out = where.file;
    if (where.line > 0) {
        out += ':';
        out += std::to_string(where.line);
    }
    if (!out.empty()) out += ": ";
    out += severity == Severity::Error ? "error: " : "warning: ";
    out += message;
    return out;
}

void Diagnostics::error(const SourceLoc& where, std::string message) {
    items_.push_back(Diagnostic{Severity::Error, where, std::move(message)});
    ++errorCount_;
}

void Diagnostics::warning(const SourceLoc& where, std::string message) {
    items_.push_back(Diagnostic{Severity::Warning, where, std::move(message)});
}

void Diagnostics::print(std::ostream& out) const {
    for (const Diagnostic& d : items_) out << d.format() << '\n';
}

namespace {

std::string lower(const std::string& s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return out;
}

/// Levenshtein distance (insertions, deletions and substitutions all cost 1), two-row version.
std::size_t editDistance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        cur[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t substitution = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
            cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, substitution});
        }
        std::swap(prev, cur);
    }
    return prev[b.size()];
}

}  // namespace

std::string closestMatch(const std::string& word, const std::vector<std::string>& candidates) {
    if (word.empty()) return "";
    const std::string w = lower(word);
    // Allow more typos in longer words: 2 edits, or a third of the word's length.
    const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
    std::string best;
    std::size_t bestDistance = limit + 1;
    for (const std::string& c : candidates) {
        const std::size_t d = editDistance(w, lower(c));
        if (d < bestDistance) {  // strict: the first of equally close candidates wins
            bestDistance = d;
            best = c;
        }
    }
    return best;
}

bool equalsIgnoreCase(const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i])))
            return false;
    return true;
}

}  // namespace ch
