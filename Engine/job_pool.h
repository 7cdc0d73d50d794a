// crowdhealth — the job pool shared by `sweep` and `calibrate`: a list of independent jobs (each a
// short text: what to run) handed out one at a time to whoever is free, and their results (each a
// short text) collected on the controlling process.
//
// Locally the workers are threads of this process. Under MPI (`mpirun -n K crowdhealth …`) rank 0
// is the controller and ranks 1 … K−1 are the workers (see docs/sweeps.md): every rank runs the
// same command and builds the same JobPool; rank 0 calls run(), the others call serve(). Jobs
// and results travel as text, so the caller's code is the same either way.
//
// The contract for a command under MPI:
//  * only the controller prints and writes files; the other ranks check what they need quietly;
//  * checks whose outcome can differ between ranks (a file one host cannot read) end with
//    agree(status) on every rank: when it returns non-zero, every rank returns that status and
//    nobody calls run() or serve();
//  * then the controller calls run() (once or more) and finish(status); the workers call serve()
//    and return exitStatus(), so that every rank exits with the command's status.
// MPI is started only when the program was launched by mpirun or srun (the plain program never
// calls MPI_Init) and finalised at the end of the process. With one rank (`mpirun -n 1`) the
// controller runs the jobs on local threads. Built without MPI (CMake option CROWDHEALTH_MPI
// OFF), a process is a controller with local threads; launched by mpirun anyway, rank 0 (read
// from the launcher's variables) does all the work with a warning and the others serve nothing.
//
// Results must depend only on the job text (each job runs on one thread with its own seed), so the
// outputs do not depend on the number of workers, on MPI, or on the order the jobs finish in.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace chcli {

/// Runs one job: job text → result text. Called on a worker thread (or rank); must be
/// thread-safe, must not print, and must not throw (turn failures into a result text). It may
/// store the simulated time of the run it is doing in `clock` (display only).
using JobWork = std::function<std::string(const std::string& job, std::atomic<double>& clock)>;

struct JobPoolOptions {
    std::size_t localJobs = 0;  ///< threads when not under MPI (0: one per hardware thread)
};

/// What the controller sees while jobs run (for a progress line).
struct JobPoolState {
    std::size_t done = 0;     ///< results received in this run()
    std::size_t running = 0;  ///< jobs handed out and not finished
    double slowest = 0;       ///< smallest `clock` among the running jobs (NaN when not known)
};

class JobPool {
public:
    JobPool(JobWork work, JobPoolOptions options);
    ~JobPool();
    JobPool(const JobPool&) = delete;
    JobPool& operator=(const JobPool&) = delete;

    /// True on the process that drives the study: always without MPI, rank 0 under MPI. Only
    /// the controller calls run(); the others call serve().
    bool controller() const;
    /// How many jobs can run at once (threads, or MPI ranks − 1; threads again with one rank).
    std::size_t workers() const;

    /// Controller: runs every job, at most workers() at a time. `done(index, result)` is called
    /// on this thread for each job as it finishes (completion order, not index order); `tick`
    /// about ten times a second. Returns false when interrupted (Ctrl-C, see signals.h) before
    /// every job finished: the jobs going are finished or abandoned, none is started after.
    /// May be called several times (calibration evaluates one batch per step of its search).
    bool run(const std::vector<std::string>& jobs,
             const std::function<void(std::size_t index, const std::string& result)>& done,
             const std::function<void(const JobPoolState&)>& tick = {});

    /// Worker ranks: run the jobs the controller sends until it says the study is over (its
    /// JobPool is destroyed or finish() called). Returns immediately without MPI.
    void serve();
    /// Controller: tells the workers the study is over (also done by the destructor).
    void finish();
    /// The same, handing `exitStatus` to the workers: after serve() they read it from exitStatus().
    void finish(int exitStatus);
    /// Worker ranks, after serve(): the status the controller passed to finish() (0 if none).
    int exitStatus() const { return exitStatus_; }

    /// Every rank (a collective under MPI): combines the outcome of checks each rank made for
    /// itself and returns the largest status. Non-zero: the study does not start, no rank may
    /// call run() or serve(), and finish() sends nothing. Without MPI it returns `status`.
    int agree(int status);
    /// True under MPI with at least one worker rank (jobs leave this process).
    bool distributed() const { return ranks() > 1; }

    /// This process's MPI rank and the number of ranks (0 and 1 without MPI). The first call of
    /// either (or the first JobPool) starts MPI when the program was launched by mpirun or srun,
    /// so a command can ask before it builds its pool (e.g. to print its errors on rank 0 only).
    static int rank();
    static int ranks();

private:
    bool runLocal(const std::vector<std::string>& jobs,
                  const std::function<void(std::size_t, const std::string&)>& done,
                  const std::function<void(const JobPoolState&)>& tick);
    bool runDistributed(const std::vector<std::string>& jobs,
                        const std::function<void(std::size_t, const std::string&)>& done,
                        const std::function<void(const JobPoolState&)>& tick);

    JobWork work_;
    JobPoolOptions options_;
    bool finished_ = false;
    int exitStatus_ = 0;
};

}  // namespace chcli
