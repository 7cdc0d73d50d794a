"""Trajectories into numpy: runs the room of Examples/room, takes the positions of every agent
every 0.5 s into one array per agent (agents leave at the exit, so rows are keyed by id), and
measures each path: length, straightness and mean speed. Saves trajectories.npz and paths.png.

    PYTHONPATH=build/python python3 Examples/python/trajectories.py [--out DIR]
"""
import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import crowdhealth

HERE = pathlib.Path(__file__).resolve().parent


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="folder for trajectories.npz and paths.png")
    out = pathlib.Path(ap.parse_args().out)
    sim = crowdhealth.Simulation(HERE.parent / "room" / "exit-socialforces-steps.xml", seed=1)

    frames = {}  # id -> list of (t, x, y)
    interval = 0.5
    while True:
        for i, (x, y) in zip(sim.ids(), sim.positions()):
            frames.setdefault(int(i), []).append((sim.time, x, y))
        if sim.finished:
            break
        sim.run(until=sim.time + interval)
    paths = {i: np.array(rows) for i, rows in frames.items()}  # each: K x 3 (t, x, y)

    lengths = np.array([np.linalg.norm(np.diff(p[:, 1:], axis=0), axis=1).sum() for p in paths.values()])
    direct = np.array([np.linalg.norm(p[-1, 1:] - p[0, 1:]) for p in paths.values()])
    durations = np.array([p[-1, 0] - p[0, 0] for p in paths.values()])
    print("%d agents, %d frames, evacuated %d by t = %.1f s" % (len(paths), max(len(p) for p in paths.values()),
                                                             sim.evacuated, sim.time))
    print("path length %.2f m (median), straightness %.2f, mean speed %.2f m/s" %
          (np.median(lengths), np.median(direct / lengths), np.median(lengths / durations)))
    np.savez(out / "trajectories.npz", **{"agent_%d" % i: p for i, p in paths.items()})

    fig, ax = plt.subplots(figsize=(6, 5))
    for p in paths.values():
        ax.plot(p[:, 1], p[:, 2], "-", lw=0.6, color=plt.cm.viridis(p[0, 2] / 10))
        ax.plot(p[0, 1], p[0, 2], ".", ms=3, color="k")
    for x, y, w, h in [(-1, -1, 1, 12), (0, -1, 10, 1), (0, 10, 10, 1), (10, -1, 1, 5.4), (10, 5.6, 1, 5.4)]:
        ax.add_patch(plt.Rectangle((x, y), w, h, color="0.4"))
    ax.set_aspect("equal"), ax.set_xlim(-2, 14), ax.set_ylim(-2, 12)
    ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)")
    ax.set_title("Paths every %.1f s to the exit (start: dot)" % interval)
    fig.tight_layout()
    fig.savefig(out / "paths.png", dpi=100)
    print("wrote", out / "trajectories.npz", "and", out / "paths.png")


if __name__ == "__main__":
    main()
