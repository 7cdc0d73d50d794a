/* CrowdHealth C API example (docs/c-api.md): load a scenario, run it for 10 s, read the agents,
 * change a parameter mid-run, and show what errors look like. The test suite builds this file
 * against an installed tree (Tests/capi_install_test.sh) and checks its output.
 *
 *   gcc -std=c99 example.c $(pkg-config --cflags --libs crowdhealth) -lm -o example
 *   ./example scenario.xml [bad-scenario.xml]
 */
#include <crowdhealth/crowdhealth_c.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* Mean distance (m) the agents present in both snapshots moved between them, matched by id. */
static double mean_displacement(const int64_t* ids0, const double* xy0, size_t n0, const int64_t* ids1,
                                const double* xy1, size_t n1) {
    double sum = 0;
    size_t matched = 0;
    for (size_t i = 0; i < n1; ++i)
        for (size_t j = 0; j < n0; ++j)
            if (ids1[i] == ids0[j]) {
                sum += hypot(xy1[2 * i] - xy0[2 * j], xy1[2 * i + 1] - xy0[2 * j + 1]);
                ++matched;
                break;
            }
    return matched ? sum / (double)matched : 0;
}

int main(int argc, char** argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s scenario.xml [bad-scenario.xml]\n", argv[0]);
        return 2;
    }
    printf("CrowdHealth %s\n", ch_version());

    /* Load with the seed 7 instead of the scenario's (pass NULL to keep it). */
    const uint64_t seed = 7;
    ch_simulation* sim = ch_simulation_load(argv[1], &seed);
    if (sim == NULL) {
        fprintf(stderr, "%s\n", ch_last_error());
        return 1;
    }
    ch_simulation_set_threads(sim, 2);

    /* Ask for the count first (capacity 0), then read into buffers of that size. */
    size_t n0 = 0;
    if (ch_simulation_positions(sim, NULL, 0, &n0) == CH_ERROR_BUFFER_TOO_SMALL)
        printf("too small: %s\n", ch_last_error());
    int64_t* ids0 = malloc((n0 + 1) * sizeof *ids0);
    double* xy0 = malloc((2 * n0 + 1) * sizeof *xy0);
    if (ids0 == NULL || xy0 == NULL) return 1;
    ch_simulation_agent_ids(sim, ids0, n0, NULL);
    ch_simulation_positions(sim, xy0, n0, NULL);
    printf("t = %.2f s: %zu agents (dt %.2f s, end time %.1f s)\n", ch_simulation_time(sim), n0,
           ch_simulation_delta_time(sim), ch_simulation_end_time(sim));

    /* Change a parameter mid-run, addressed as <Ramp> does: policy 0, component, parameter. */
    double v0 = 0;
    ch_simulation_get_parameter(sim, 0, "SocialForcesAvoidance", "V0", &v0);
    if (ch_simulation_set_parameter(sim, 0, "SocialForcesAvoidance", "V0", 2 * v0) != CH_OK) {
        fprintf(stderr, "%s\n", ch_last_error());
        return 1;
    }
    double v0now = 0;
    ch_simulation_get_parameter(sim, 0, "SocialForcesAvoidance", "V0", &v0now);
    printf("SocialForcesAvoidance.V0: %g -> %g\n", v0, v0now);
    /* A misspelt name fails and says why; nothing is changed. */
    if (ch_simulation_set_parameter(sim, 0, "SocialForcesAvoidance", "V_0", 1.0) == CH_ERROR_UNKNOWN_NAME)
        printf("set_parameter failed: %s\n", ch_last_error());

    /* 10 s of simulated time, one coarse step at a time. */
    while (ch_simulation_time(sim) < 10 - 1e-9 && !ch_simulation_finished(sim)) {
        if (ch_simulation_step(sim) != CH_OK) {
            fprintf(stderr, "%s\n", ch_last_error());
            return 1;
        }
    }

    size_t n1 = ch_simulation_agent_count(sim);
    int64_t* ids1 = malloc((n1 + 1) * sizeof *ids1);
    double* xy1 = malloc((2 * n1 + 1) * sizeof *xy1);
    double* v1 = malloc((2 * n1 + 1) * sizeof *v1);
    if (ids1 == NULL || xy1 == NULL || v1 == NULL) return 1;
    ch_simulation_agent_ids(sim, ids1, n1, NULL);
    ch_simulation_positions(sim, xy1, n1, NULL);
    ch_simulation_velocities(sim, v1, n1, NULL);
    double speed = 0;
    for (size_t i = 0; i < n1; ++i) speed += hypot(v1[2 * i], v1[2 * i + 1]);
    printf("t = %.2f s: %zu agents, mean displacement %.3f m, mean speed %.3f m/s\n", ch_simulation_time(sim), n1,
           mean_displacement(ids0, xy0, n0, ids1, xy1, n1), n1 ? speed / (double)n1 : 0.0);
    if (n1 > 0) printf("agent %lld at (%.3f, %.3f)\n", (long long)ids1[0], xy1[0], xy1[1]);

    free(ids0), free(xy0), free(ids1), free(xy1), free(v1);
    ch_simulation_free(sim);

    /* A scenario with errors: NULL, and the loader's `path:line: error:` lines. */
    if (argc > 2) {
        ch_simulation* bad = ch_simulation_load(argv[2], NULL);
        if (bad == NULL) printf("load failed:\n%s\n", ch_last_error());
        ch_simulation_free(bad);
    }
    return 0;
}
