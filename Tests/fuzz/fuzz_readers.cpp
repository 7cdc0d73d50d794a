// libFuzzer target: the readers of trajectories and run folders (fuzz_entry.h).
#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    ch::fuzz::readersInput(data, size);
    return 0;
}
