// CrowdHealth — when loops run on the OpenMP team (see parallel.h).
#include "crowdhealth/core/parallel.h"

#include <atomic>
#include <cstdlib>
#include <string>

namespace ch {

namespace {
std::atomic<std::size_t>& threshold() {
    static std::atomic<std::size_t> value = [] {
        std::size_t n = 1000;
        if (const char* env = std::getenv("CROWDHEALTH_PARALLEL_MIN_AGENTS")) {
            try {
                n = static_cast<std::size_t>(std::stoul(env));
            } catch (const std::exception&) {
                // not a number: keep the default (the setting only changes speed)
            }
        }
        return n;
    }();
    return value;
}
}  // namespace

std::size_t parallelMinAgents() { return threshold().load(std::memory_order_relaxed); }
void setParallelMinAgents(std::size_t n) { threshold().store(n, std::memory_order_relaxed); }

}  // namespace ch
