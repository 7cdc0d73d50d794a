// libFuzzer target: the scenario loader and the --check path (fuzz_entry.h).
#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    ch::fuzz::loaderInput(data, size);
    return 0;
}
