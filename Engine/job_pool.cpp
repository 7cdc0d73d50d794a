// crowdhealth — the job pool (job_pool.h): local threads.
#include "job_pool.h"

#include "signals.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>

namespace chcli {

JobPool::JobPool(JobWork work, JobPoolOptions options) : work_(std::move(work)), options_(options) {}

JobPool::~JobPool() { finish(); }

bool JobPool::controller() const { return true; }

std::size_t JobPool::workers() const {
    if (options_.localJobs > 0) return options_.localJobs;
    return std::max(1u, std::thread::hardware_concurrency());
}

void JobPool::serve() {}

void JobPool::finish() { finished_ = true; }

bool JobPool::run(const std::vector<std::string>& jobs,
                  const std::function<void(std::size_t, const std::string&)>& done,
                  const std::function<void(const JobPoolState&)>& tick) {
    const std::size_t n = jobs.size();
    if (n == 0) return !interruptRequested();
    const std::size_t threads = std::min(n, workers());
    std::mutex mutex;
    std::condition_variable wake;
    std::vector<std::pair<std::size_t, std::string>> finished;  // not yet passed to done()
    std::size_t going = threads, received = 0;
    std::atomic<std::size_t> next{0};
    const std::unique_ptr<std::atomic<double>[]> clocks(new std::atomic<double>[n]);
    const std::unique_ptr<std::atomic<int>[]> phase(new std::atomic<int>[n]);  // 0 waiting, 1 going, 2 over
    for (std::size_t k = 0; k < n; ++k) {
        clocks[k] = 0;
        phase[k] = 0;
    }
    auto worker = [&] {
        for (;;) {
            if (interruptRequested()) break;
            const std::size_t k = next.fetch_add(1);
            if (k >= n) break;
            phase[k] = 1;
            std::string result = work_(jobs[k], clocks[k]);
            phase[k] = 2;
            {
                const std::lock_guard<std::mutex> lock(mutex);
                finished.emplace_back(k, std::move(result));
            }
            wake.notify_one();
        }
        {
            const std::lock_guard<std::mutex> lock(mutex);
            --going;
        }
        wake.notify_one();
    };
    std::vector<std::thread> pool;
    for (std::size_t w = 0; w < threads; ++w) pool.emplace_back(worker);
    {
        std::unique_lock<std::mutex> lock(mutex);
        for (;;) {
            wake.wait_for(lock, std::chrono::milliseconds(100), [&] { return !finished.empty() || going == 0; });
            std::vector<std::pair<std::size_t, std::string>> now;
            now.swap(finished);
            const bool over = going == 0;
            lock.unlock();
            for (const auto& [k, result] : now) done(k, result);
            received += now.size();
            if (tick) {
                JobPoolState st;
                st.done = received;
                st.slowest = std::numeric_limits<double>::infinity();
                for (std::size_t k = 0; k < n; ++k)
                    if (phase[k].load() == 1) {
                        ++st.running;
                        st.slowest = std::min(st.slowest, clocks[k].load(std::memory_order_relaxed));
                    }
                if (st.running == 0) st.slowest = 0;
                tick(st);
            }
            lock.lock();
            if (over && finished.empty()) break;
        }
    }
    for (std::thread& t : pool) t.join();
    return received == n;
}

}  // namespace chcli
