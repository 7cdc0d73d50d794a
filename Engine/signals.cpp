// crowdhealth — Ctrl-C handling (see signals.h).
#include "signals.h"

#include <atomic>
#include <csignal>

namespace chcli {

namespace {
// Only lock-free atomics may be touched in a signal handler.
static_assert(std::atomic<int>::is_always_lock_free);
std::atomic<int> g_signal{0};

extern "C" void onInterrupt(int signo) { g_signal.store(signo, std::memory_order_relaxed); }
}  // namespace

void installInterruptHandlers() {
    struct sigaction sa {};
    sa.sa_handler = onInterrupt;
    sigemptyset(&sa.sa_mask);
    // SA_RESETHAND: the next signal gets the default action (terminate), so a second Ctrl-C
    // still works if the current step never ends. SA_RESTART: writes in progress are not cut.
    sa.sa_flags = SA_RESETHAND | SA_RESTART;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

bool interruptRequested() { return g_signal.load(std::memory_order_relaxed) != 0; }
int interruptSignal() { return g_signal.load(std::memory_order_relaxed); }

}  // namespace chcli
