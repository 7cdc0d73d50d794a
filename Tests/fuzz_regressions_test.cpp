// CrowdHealth tests — every input that once made a libFuzzer target crash or report (Tests/fuzz/
// regressions/<target>/), replayed through the same entry points (fuzz_entry.h) in the normal
// build: each must now be read without a crash (the sanitizer run also checks memory and UB).
// scripts/fuzz.sh copies new reproducers there; docs/development.md.
#define BOOST_TEST_MODULE fuzz_regressions
#include <boost/test/unit_test.hpp>

#include "fuzz_entry.h"

#include <algorithm>
#include <fstream>
#include <iterator>

namespace fs = std::filesystem;

namespace {
std::vector<fs::path> inputs(const std::string& target) {
    std::vector<fs::path> out;
    const fs::path dir = fs::path(CH_SOURCE_DIR) / "Tests" / "fuzz" / "regressions" / target;
    if (fs::exists(dir))
        for (const auto& e : fs::directory_iterator(dir))
            if (e.is_regular_file() && e.path().filename() != "README.md") out.push_back(e.path());
    std::sort(out.begin(), out.end());
    return out;
}
std::string bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}
template <class F>
void replay(const std::string& target, F entry) {
    const std::vector<fs::path> files = inputs(target);
    BOOST_TEST_MESSAGE(target << ": " << files.size() << " reproducer(s)");
    for (const fs::path& f : files) {
        BOOST_TEST_CONTEXT(f.filename().string()) {
            const std::string b = bytes(f);
            BOOST_CHECK_NO_THROW(entry(reinterpret_cast<const std::uint8_t*>(b.data()), b.size()));
        }
    }
}
}  // namespace

BOOST_AUTO_TEST_CASE(loader_reproducers_load_cleanly) { replay("loader", ch::fuzz::loaderInput); }
BOOST_AUTO_TEST_CASE(reader_reproducers_are_read_cleanly) { replay("readers", ch::fuzz::readersInput); }

BOOST_AUTO_TEST_CASE(inputs_are_split_into_files_at_the_separator) {
    const std::string in = "a\n--FILE--\nb\n--FILE--\nc\n--FILE--\nd";
    const auto parts = ch::fuzz::splitFiles(reinterpret_cast<const std::uint8_t*>(in.data()), in.size(), 3);
    BOOST_TEST(parts.size() == 3u);
    BOOST_TEST(parts[0] == "a");
    BOOST_TEST(parts[1] == "b");
    BOOST_TEST(parts[2] == "c\n--FILE--\nd");  // the last part takes the rest
}
