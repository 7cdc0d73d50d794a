/* CrowdHealth — the C API (C99): load a scenario, step it, read the agents, change a parameter.
 *
 * One boundary for every language (docs/c-api.md): opaque handles, plain C types, and no C++
 * exception ever crosses it. Link with `pkg-config --cflags --libs crowdhealth` or, in CMake,
 * find_package(CrowdHealth) and the target CrowdHealth::crowdhealth.
 *
 * ERRORS. Every call that can fail returns CH_OK (0) or a negative ch_status, or NULL for
 * ch_simulation_load. On failure the message is kept for the calling thread until its next
 * failing call: read it with ch_last_error(). A successful call does not clear it.
 *
 * THREADS. A handle may be used by one thread at a time (calls on one handle are not
 * synchronised); different handles may be used from different threads at once. The simulation's
 * own parallel phases use `threads` OpenMP threads (ch_simulation_set_threads), whichever thread
 * calls ch_simulation_step; results do not depend on the thread count.
 *
 * UNITS. Metres, seconds, metres per second.
 */
#ifndef CROWDHEALTH_CROWDHEALTH_C_H
#define CROWDHEALTH_CROWDHEALTH_C_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define CH_C_API
#else
#define CH_C_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/** A loaded scenario being simulated. Create with ch_simulation_load, destroy with ch_simulation_free. */
typedef struct ch_simulation ch_simulation;

/** Results of the calls that can fail. */
typedef enum ch_status {
    CH_OK = 0,
    CH_ERROR_NULL_ARGUMENT = -1,      /**< a handle or pointer argument was NULL */
    CH_ERROR_BUFFER_TOO_SMALL = -2,   /**< the caller's buffer holds fewer agents than there are */
    CH_ERROR_UNKNOWN_NAME = -3,       /**< set_parameter: no such component, parameter or policy */
    CH_ERROR_INVALID_VALUE = -4,      /**< set_parameter: value out of the parameter's range, or not settable */
    CH_ERROR_RUNTIME = -5             /**< the simulation failed (message in ch_last_error) */
} ch_status;

/** ch_simulation_set_parameter's `policy_id` for "every policy that has the component" (as a
 *  <Ramp> without policy="…"). */
#define CH_ALL_POLICIES (-1)

/** The library's version, "MAJOR.MINOR.PATCH" (the project's version). Never NULL. */
CH_C_API const char* ch_version(void);

/** The message of the calling thread's last failed call ("" if none yet). The text stays valid
 *  until the thread's next failing call. Load errors hold the loader's diagnostics, one per
 *  line, in the `path:line: error: message` form of the program. Never NULL. */
CH_C_API const char* ch_last_error(void);

/** Loads a plugin (a shared library of cost functions and forces, crowdhealth/plugin.h) so that
 *  scenarios loaded afterwards can use its components, as `crowdhealth --plugin FILE` does (a
 *  scenario can also name it: <Plugin file="…"/>). A file loaded before is not loaded again.
 *  Returns CH_OK, or CH_ERROR_RUNTIME with the file and the reason in ch_last_error(). */
CH_C_API ch_status ch_load_plugin(const char* path);

/** Loads the scenario file at `path` exactly as the `crowdhealth` program does (every file it
 *  names, relative to the file naming it) and builds its simulation at time 0.
 *  `seed`: NULL keeps the scenario's Simulation@seed; otherwise overrides it (as --seed).
 *  Returns NULL on failure (ch_last_error() then holds every error found). */
CH_C_API ch_simulation* ch_simulation_load(const char* path, const uint64_t* seed);

/** Destroys a simulation. NULL is allowed and ignored. */
CH_C_API void ch_simulation_free(ch_simulation* sim);

/** Loader warnings of this scenario (`path:line: warning: …` lines), "" if none. Valid as long
 *  as the handle; NULL if `sim` is NULL. */
CH_C_API const char* ch_simulation_warnings(const ch_simulation* sim);

/** OpenMP threads for the simulation's parallel phases (default 1; n < 1 counts as 1). The
 *  results are the same for every thread count. */
CH_C_API ch_status ch_simulation_set_threads(ch_simulation* sim, int threads);

/** Advances one coarse step (Simulation@delta_time). Stepping on after the end time or after
 *  everyone has left is allowed (time advances; nobody moves). */
CH_C_API ch_status ch_simulation_step(ch_simulation* sim);

/** Simulated time (s). NaN (and an error) if `sim` is NULL. */
CH_C_API double ch_simulation_time(const ch_simulation* sim);

/** The coarse step (s), Simulation@delta_time. NaN if `sim` is NULL. */
CH_C_API double ch_simulation_delta_time(const ch_simulation* sim);

/** The scenario's end time (s), or a negative value when it has none. NaN if `sim` is NULL. */
CH_C_API double ch_simulation_end_time(const ch_simulation* sim);

/** 1 once time has reached the end time or no agent is left (active or still to come), else 0.
 *  Without an end time a run whose agents never leave never finishes: stop it yourself.
 *  -1 if `sim` is NULL. */
CH_C_API int ch_simulation_finished(const ch_simulation* sim);

/** Number of agents in the world now (activated and not yet removed). 0 if `sim` is NULL. */
CH_C_API size_t ch_simulation_agent_count(const ch_simulation* sim);

/** The agents now in the world, in the simulation's internal order (the same order for the
 *  three calls between two steps; it changes as agents come, leave and are re-ordered, so match
 *  agents by id). `capacity` is the number of AGENTS the buffer can hold:
 *    ids:        capacity int64_t values;
 *    positions:  2·capacity doubles, x0 y0 x1 y1 … (m);
 *    velocities: 2·capacity doubles, vx0 vy0 … (m/s).
 *  `count` (may be NULL) receives the number of agents. When capacity < agent count nothing is
 *  written to the buffer, *count holds the size needed, and CH_ERROR_BUFFER_TOO_SMALL is
 *  returned. The buffer may be NULL when capacity is 0 (to ask for the count). */
CH_C_API ch_status ch_simulation_agent_ids(const ch_simulation* sim, int64_t* ids, size_t capacity, size_t* count);
CH_C_API ch_status ch_simulation_positions(const ch_simulation* sim, double* xy, size_t capacity, size_t* count);
CH_C_API ch_status ch_simulation_velocities(const ch_simulation* sim, double* vxy, size_t capacity, size_t* count);

/** Sets a parameter of a policy's component now, addressed as <Ramp> addresses it:
 *  `policy_id` (the <Policy id>, or CH_ALL_POLICIES for every policy that has the component),
 *  `component` (the registered name, e.g. "SocialForcesAvoidance", or "CrowdHealth" for the
 *  health layer of the policy) and `parameter` (a real parameter of its table, as listed by
 *  `crowdhealth --list-policies`). The value is checked against the parameter's range. It takes
 *  effect at the next step and stays until set again, or until a <Ramp> of the scenario on the
 *  same parameter writes a new value.
 *  Fails with CH_ERROR_UNKNOWN_NAME when the component or parameter does not exist or no
 *  selected policy has the component, and CH_ERROR_INVALID_VALUE when the value is out of range
 *  or the parameter cannot change while running; nothing is changed then. */
CH_C_API ch_status ch_simulation_set_parameter(ch_simulation* sim, int policy_id, const char* component,
                                               const char* parameter, double value);

/** Reads the current value of a parameter addressed as above (the first matching component).
 *  Fails as ch_simulation_set_parameter does; *value is left unchanged then. */
CH_C_API ch_status ch_simulation_get_parameter(const ch_simulation* sim, int policy_id, const char* component,
                                               const char* parameter, double* value);

#ifdef __cplusplus
}
#endif

#endif /* CROWDHEALTH_CROWDHEALTH_C_H */
