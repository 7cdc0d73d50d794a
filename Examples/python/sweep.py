"""A parameter sweep with a plot: how the width of a room's exit sets the evacuation time and the
flow. Each room is built in code (crowdhealth.Scenario), run to the end, and measured; the plot is
written to sweep.png (matplotlib, no display needed).

    PYTHONPATH=build/python python3 Examples/python/sweep.py [--out DIR]
"""
import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import crowdhealth


def room(exit_width, seed):
    """An 8 x 8 m room, 64 people on a grid, one exit of `exit_width` m in the right wall."""
    s = crowdhealth.Scenario(delta_time=0.1, delta_time_fine=0.05, end_time=120, seed=seed)
    s.world("planar", xmin=-2, xmax=12, ymin=-2, ymax=10)
    low, high = 4 - exit_width / 2, 4 + exit_width / 2
    s.box(-1, -1, 1, 10).box(0, -1, 8, 1).box(0, 8, 8, 1)
    s.box(8, -1, 1, low + 1).box(8, high, 1, 9 - high)  # the right wall, split by the exit
    s.policy(0, ["GoalReachingForce"], timing="coarse", relaxation_time=0.5)
    s.step(0, [("SocialForcesAvoidance", {"range": 3})], timing="fine", relaxation_time=0.5)
    s.output(flow_first=5, flow_last=55)
    rng = np.random.default_rng(seed)
    grid = np.array([(0.6 + i, 0.6 + j) for i in range(8) for j in range(8)]) * 0.85
    grid += rng.uniform(-0.05, 0.05, grid.shape)
    s.agents(grid, goal=(10, 4), remove_at_goal=True, goal_radius=0.5)
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="folder for sweep.png")
    out = pathlib.Path(ap.parse_args().out)
    widths = [1.0, 1.2, 1.6, 2.0, 2.4]
    seeds = [1, 2]
    times, flows = [], []
    for w in widths:
        t, f = [], []
        for seed in seeds:
            sim = crowdhealth.Simulation(room(w, seed))
            sim.run()
            summary = sim.summary()
            t.append(summary["evacuation_time"] if summary["evacuation_time"] is not None else np.nan)
            f.append(summary["flow"]["persons_per_second"] or np.nan)
        times.append(t)
        flows.append(f)
        print("exit %.1f m: evacuation %s s, flow %s P/s" % (w, np.round(t, 1), np.round(f, 2)))
    times, flows = np.array(times, float), np.array(flows, float)

    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    each = np.repeat(widths, len(seeds))
    a.plot(each, times.ravel(), "o", color="0.6", label="one run")
    a.plot(widths, np.nanmean(times, axis=1), "-", color="C0", label="mean of %d seeds" % len(seeds))
    a.set_xlabel("exit width (m)"), a.set_ylabel("evacuation time (s)"), a.legend()
    b.plot(each, (flows / np.array(widths)[:, None]).ravel(), "o", color="0.6", label="one run")
    b.plot(widths, np.nanmean(flows, axis=1) / widths, "-", color="C1", label="mean")
    b.set_xlabel("exit width (m)"), b.set_ylabel("specific flow (P/(m s))")
    b.set_ylim(bottom=0), b.legend()
    fig.suptitle("64 people leave an 8 m x 8 m room (social forces)")
    fig.tight_layout()
    fig.savefig(out / "sweep.png", dpi=100)
    print("wrote", out / "sweep.png")


if __name__ == "__main__":
    main()
