// CrowdHealth — SharedName: an immutable string held by reference, for the names that many agent
// specs repeat (their journey and group).
//
// A std::string member takes 32 bytes in every AgentSpec, even empty; a SharedName takes 8 (one
// pointer, null when empty), and its copies share one reference-counted heap block. An AgentGrid of
// a million agents on one journey, in groups of three, holds one journey block and 333,334 group
// blocks instead of two strings per agent (issue 20: the specs coexist with the agent store at
// setup). Unlike FileName (io/diagnostics.h) nothing is interned in a pool: the last copy frees the
// block, so a process that loads many scenarios keeps nothing of the old ones.
//
// It reads as a const std::string: converts to one, compares with strings and string literals
// (by content), concatenates with them and prints. Copies may be made and destroyed on several
// threads at once (the count is atomic); the text itself is never written after construction.
#pragma once

#include <atomic>
#include <cstddef>
#include <ostream>
#include <string>
#include <utility>

namespace ch {

class SharedName {
public:
    SharedName() noexcept = default;
    SharedName(const std::string& text) : block_(text.empty() ? nullptr : new Block{{1}, text}) {}  // NOLINT(google-explicit-constructor)
    SharedName(std::string&& text)  // NOLINT(google-explicit-constructor)
        : block_(text.empty() ? nullptr : new Block{{1}, std::move(text)}) {}
    SharedName(const char* text) : SharedName(std::string(text)) {}  // NOLINT(google-explicit-constructor)
    SharedName(const SharedName& other) noexcept : block_(other.block_) {
        if (block_ != nullptr) block_->refs.fetch_add(1, std::memory_order_relaxed);
    }
    SharedName(SharedName&& other) noexcept : block_(std::exchange(other.block_, nullptr)) {}
    SharedName& operator=(SharedName other) noexcept {
        std::swap(block_, other.block_);
        return *this;
    }
    ~SharedName() {
        if (block_ != nullptr && block_->refs.fetch_sub(1, std::memory_order_acq_rel) == 1) delete block_;
    }

    const std::string& str() const noexcept { return block_ != nullptr ? block_->text : empty_(); }
    operator const std::string&() const noexcept { return str(); }  // NOLINT(google-explicit-constructor)
    bool empty() const noexcept { return block_ == nullptr; }
    const char* c_str() const noexcept { return str().c_str(); }
    std::size_t size() const noexcept { return str().size(); }

    friend bool operator==(const SharedName& a, const SharedName& b) { return a.block_ == b.block_ || a.str() == b.str(); }
    friend bool operator==(const SharedName& a, const std::string& b) { return a.str() == b; }
    friend bool operator==(const SharedName& a, const char* b) { return a.str() == b; }
    friend std::string operator+(const SharedName& a, const std::string& b) { return a.str() + b; }
    friend std::string operator+(const std::string& a, const SharedName& b) { return a + b.str(); }
    friend std::string operator+(const SharedName& a, const char* b) { return a.str() + b; }
    friend std::string operator+(const char* a, const SharedName& b) { return a + b.str(); }
    friend std::ostream& operator<<(std::ostream& out, const SharedName& n) { return out << n.str(); }

private:
    struct Block {
        std::atomic<std::size_t> refs;
        std::string text;
    };
    static const std::string& empty_() noexcept {
        static const std::string none;
        return none;
    }
    Block* block_ = nullptr;
};

}  // namespace ch
