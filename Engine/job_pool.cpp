// crowdhealth — the job pool (job_pool.h): local threads, and MPI ranks when built with
// CROWDHEALTH_MPI and launched by mpirun or srun.
#include "job_pool.h"

#include "signals.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <iostream>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>

#ifdef CROWDHEALTH_MPI
#include <mpi.h>
#endif

namespace chcli {

namespace {

#ifdef CROWDHEALTH_MPI
// ---- MPI ---------------------------------------------------------------------------------------
//
// Messages between rank 0 and a worker rank, all of chars: a job (kTagJob: 8 bytes of job index,
// then the job text), its result (kTagResult: the same index, then the result text), and the end
// of the study (kTagStop: 4 bytes, the exit status). Only the main thread of a process calls MPI
// (MPI_THREAD_FUNNELED); the local threads of `mpirun -n 1` never do.
constexpr int kTagJob = 1, kTagResult = 2, kTagStop = 3;

/// Launched by mpirun (OpenMPI sets OMPI_COMM_WORLD_SIZE) or by srun/another PMI launcher.
bool launchedByMpi() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(name) != nullptr) return true;
    return false;
}

/// MPI for the life of the process: started on first use when launched by mpirun/srun,
/// finalised when the process ends (static destruction after main returns).
struct MpiSession {
    bool active = false;
    int rank = 0, size = 1;
    MpiSession() {
        if (!launchedByMpi()) return;
        int provided = 0;
        if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
            std::cerr << "crowdhealth: error: MPI_Init_thread failed; running without MPI\n";
            return;
        }
        active = true;
        MPI_Comm_rank(MPI_COMM_WORLD, &rank);
        MPI_Comm_size(MPI_COMM_WORLD, &size);
    }
    ~MpiSession() {
        int finalized = 0;
        if (active && MPI_Finalized(&finalized) == MPI_SUCCESS && !finalized) MPI_Finalize();
    }
};

MpiSession& mpi() {
    static MpiSession session;
    return session;
}

std::string withIndex(std::uint64_t index, const std::string& text) {
    std::string m(sizeof index, '\0');
    std::memcpy(m.data(), &index, sizeof index);
    return m + text;
}

void sendText(const std::string& m, int to, int tag) {
    MPI_Send(m.data(), static_cast<int>(m.size()), MPI_CHAR, to, tag, MPI_COMM_WORLD);
}

/// Waits for a message (from `from`, any tag; or from anybody with `tag`) without spinning hard:
/// the ranks share cores with the simulations, so an idle rank polls and sleeps.
MPI_Status waitForMessage(int from, int tag, const std::function<void()>& everyPoll = {}) {
    auto pause = std::chrono::microseconds(200);
    for (;;) {
        int flag = 0;
        MPI_Status status;
        MPI_Iprobe(from, tag, MPI_COMM_WORLD, &flag, &status);
        if (flag) return status;
        if (everyPoll) everyPoll();
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::microseconds(20000));
    }
}

std::string receiveText(const MPI_Status& status) {
    int count = 0;
    MPI_Get_count(&status, MPI_CHAR, &count);
    std::string m(static_cast<std::size_t>(count), '\0');
    MPI_Recv(m.data(), count, MPI_CHAR, status.MPI_SOURCE, status.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    return m;
}

std::uint64_t indexOf(const std::string& m) {
    std::uint64_t index = std::numeric_limits<std::uint64_t>::max();
    if (m.size() >= sizeof index) std::memcpy(&index, m.data(), sizeof index);
    return index;
}
#else
/// Built without MPI but launched by mpirun/srun anyway: this process's rank and the number of
/// ranks, from the launcher's variables (0 and 1 when not launched so). Only rank 0 then works.
int launcherVariable(std::initializer_list<const char*> names, int fallback) {
    for (const char* name : names)
        if (const char* v = std::getenv(name)) {
            char* end = nullptr;
            const long n = std::strtol(v, &end, 10);
            if (end != v && *end == '\0' && n >= 0 && n < 1000000) return static_cast<int>(n);
        }
    return fallback;
}
int launcherRank() { return launcherVariable({"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"}, 0); }
int launcherSize() { return launcherVariable({"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}, 1); }
#endif

}  // namespace

int JobPool::rank() {
#ifdef CROWDHEALTH_MPI
    return mpi().rank;
#else
    return launcherRank();
#endif
}

int JobPool::ranks() {
#ifdef CROWDHEALTH_MPI
    return mpi().size;
#else
    return 1;
#endif
}

JobPool::JobPool(JobWork work, JobPoolOptions options) : work_(std::move(work)), options_(options) {
    rank();  // starts MPI if launched by mpirun/srun
#ifndef CROWDHEALTH_MPI
    // Every rank would run every job and write the same files: rank 0 alone works, on threads.
    static bool warned = false;
    if (launcherSize() > 1 && controller() && !warned) {
        warned = true;
        std::cerr << "crowdhealth: warning: launched on " << launcherSize()
                  << " MPI ranks, but this program was built without MPI (CMake option CROWDHEALTH_MPI): "
                     "rank 0 runs every job on local threads, the other ranks do nothing\n";
    }
#endif
}

JobPool::~JobPool() { finish(exitStatus_); }

bool JobPool::controller() const { return rank() == 0; }

std::size_t JobPool::workers() const {
    if (distributed()) return static_cast<std::size_t>(ranks() - 1);
    if (options_.localJobs > 0) return options_.localJobs;
    return std::max(1u, std::thread::hardware_concurrency());
}

int JobPool::agree(int status) {
#ifdef CROWDHEALTH_MPI
    if (mpi().active) {
        int all = status;
        MPI_Allreduce(&status, &all, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        status = all;
    }
#endif
    if (status != 0) {
        finished_ = true;  // nobody serves: nothing to stop
        exitStatus_ = status;
    }
    return status;
}

void JobPool::serve() {
#ifdef CROWDHEALTH_MPI
    if (controller() || finished_) return;
    for (;;) {
        const MPI_Status status = waitForMessage(0, MPI_ANY_TAG);
        const std::string m = receiveText(status);
        if (status.MPI_TAG == kTagStop) {
            if (m.size() >= sizeof(int)) std::memcpy(&exitStatus_, m.data(), sizeof(int));
            finished_ = true;
            return;
        }
        std::atomic<double> clock{0};
        const std::uint64_t index = indexOf(m);
        const std::string result = work_(m.substr(sizeof index), clock);
        sendText(withIndex(index, result), 0, kTagResult);
    }
#endif
}

void JobPool::finish() { finish(exitStatus_); }

void JobPool::finish(int exitStatus) {
    exitStatus_ = exitStatus;
    if (finished_) return;
    finished_ = true;
#ifdef CROWDHEALTH_MPI
    if (distributed() && controller()) {
        std::string m(sizeof exitStatus, '\0');
        std::memcpy(m.data(), &exitStatus, sizeof exitStatus);
        for (int r = 1; r < ranks(); ++r) sendText(m, r, kTagStop);
    }
#endif
}

bool JobPool::run(const std::vector<std::string>& jobs,
                  const std::function<void(std::size_t, const std::string&)>& done,
                  const std::function<void(const JobPoolState&)>& tick) {
    if (distributed()) return runDistributed(jobs, done, tick);
    return runLocal(jobs, done, tick);
}

bool JobPool::runDistributed(const std::vector<std::string>& jobs,
                             const std::function<void(std::size_t, const std::string&)>& done,
                             const std::function<void(const JobPoolState&)>& tick) {
#ifdef CROWDHEALTH_MPI
    const std::size_t n = jobs.size();
    if (n == 0) return !interruptRequested();
    // Dynamic load balancing: one job per worker rank; each result brings that rank the next
    // job (runs differ in length, so a fixed split would leave ranks idle). After Ctrl-C/SIGTERM
    // no job is handed out; the ones going are waited for (mpirun and srun pass the signal on to
    // every rank, so they end soon), and their results still reach done().
    std::vector<std::uint64_t> busy(static_cast<std::size_t>(ranks()), std::numeric_limits<std::uint64_t>::max());
    std::size_t next = 0, received = 0, going = 0;
    auto handOut = [&](int r) {
        if (next >= n || interruptRequested()) return;
        sendText(withIndex(next, jobs[next]), r, kTagJob);
        busy[static_cast<std::size_t>(r)] = next++;
        ++going;
    };
    auto lastTick = std::chrono::steady_clock::now();
    auto report = [&] {
        if (!tick) return;
        JobPoolState st;
        st.done = received;
        st.running = going;
        // The simulated clock of a run on another rank is not sent back.
        st.slowest = going > 0 ? std::numeric_limits<double>::quiet_NaN() : 0.0;
        tick(st);
        lastTick = std::chrono::steady_clock::now();
    };
    for (int r = 1; r < ranks(); ++r) handOut(r);
    report();
    while (going > 0) {
        const MPI_Status status = waitForMessage(MPI_ANY_SOURCE, kTagResult, [&] {
            if (std::chrono::steady_clock::now() - lastTick >= std::chrono::milliseconds(100)) report();
        });
        const std::string m = receiveText(status);
        const std::uint64_t index = indexOf(m);
        const auto from = static_cast<std::size_t>(status.MPI_SOURCE);
        if (index != busy[from]) {
            std::cerr << "crowdhealth: internal error: MPI rank " << from << " answered job " << index
                      << ", it was given job " << busy[from] << "\n";
            MPI_Abort(MPI_COMM_WORLD, 1);
        }
        busy[from] = std::numeric_limits<std::uint64_t>::max();
        --going;
        ++received;
        done(static_cast<std::size_t>(index), m.substr(sizeof index));
        handOut(status.MPI_SOURCE);
        report();
    }
    return received == n;
#else
    return runLocal(jobs, done, tick);
#endif
}

bool JobPool::runLocal(const std::vector<std::string>& jobs,
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
