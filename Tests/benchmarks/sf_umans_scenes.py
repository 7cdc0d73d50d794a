#!/usr/bin/env python3
"""Writes the SocialForces scenes of docs/performance.md's twenty-seventh round, in UMANS' format
(UMANS 1.x and crowdhealth both read them): 10,000 agents at random positions, SocialForces range
5 m + GoalReachingForce, gradient, ContactForceScale 62.5, 10 s of 0.1 s steps.

  pillars   1 m pillars every 10 m (100 obstacles) over 100 m x 100 m, 1 P/m2
  corridor  500 m x 20 m between two walls, both directions, 1 P/m2
  crossing  four groups crossing, no obstacles
  forest    0.6 m pillars every 4 m (2,500 obstacles) over 200 m x 200 m, 0.25 P/m2

Usage: sf_umans_scenes.py OUTDIR     (writes NAME.xml, and NAME-obs.xml where there are obstacles)
Then, one thread each, whole processes:
  /usr/bin/time UMANS-ConsoleApplication-Linux -i OUTDIR/forest.xml -t 1
  /usr/bin/time crowdhealth -i OUTDIR/forest.xml -o OUT -t 1 -q --trajectories none
"""
import math
import os
import random
import sys

POLICY = ('\t<Policies>\n\t\t<Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" '
          'ContactForceScale="62.5">\n\t\t\t<costfunction name="SocialForcesAvoidance" range="5" />\n'
          '\t\t\t<costfunction name="GoalReachingForce" />\n\t\t</Policy>\n\t</Policies>\n')


def write(outdir, name, agents, obstacles):
    with open(os.path.join(outdir, name + ".xml"), "w") as f:
        f.write('<?xml version="1.0" encoding="utf-8"?>\n<Simulation delta_time="0.1" end_time="10">\n')
        f.write('\t<World type="Infinite" />\n')
        if obstacles:
            f.write(f'\t<Obstacles file="{name}-obs.xml" />\n')
            with open(os.path.join(outdir, name + "-obs.xml"), "w") as g:
                g.write('<?xml version="1.0" encoding="utf-8"?>\n<Obstacles>\n')
                for poly in obstacles:
                    g.write("\t<Obstacle>\n")
                    g.writelines(f'\t\t<Point x="{x}" y="{y}"/>\n' for x, y in poly)
                    g.write("\t</Obstacle>\n")
                g.write("</Obstacles>\n")
        f.write(POLICY + "\t<Agents>\n")
        for x, y, gx, gy in agents:
            f.write(f'\t\t<Agent rad="0.24" pref_speed="1.4" max_speed="1.8" max_acceleration="5">'
                    f'<pos x="{x:.4f}" y="{y:.4f}"/><goal x="{gx:.4f}" y="{gy:.4f}"/><Policy id="0"/></Agent>\n')
        f.write("\t</Agents>\n</Simulation>\n")


def square(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def clear_of(x, y, polys, margin=0.4):
    for p in polys:
        xs, ys = [q[0] for q in p], [q[1] for q in p]
        if min(xs) - margin < x < max(xs) + margin and min(ys) - margin < y < max(ys) + margin:
            return False
    return True


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    outdir = sys.argv[1]
    os.makedirs(outdir, exist_ok=True)
    rng = random.Random(7)
    n = 10000

    def side():  # half walk +x, half -x, to goals far away
        return 1000 if rng.random() < 0.5 else -1000

    obs = [square(10 * i + 4.5, 10 * j + 4.5, 10 * i + 5.5, 10 * j + 5.5) for i in range(10) for j in range(10)]
    agents = []
    while len(agents) < n:
        x, y = rng.uniform(0, 100), rng.uniform(0, 100)
        if clear_of(x, y, obs):
            agents.append((x, y, side(), y))
    write(outdir, "pillars", agents, obs)

    obs = [square(-10, -1, 510, 0), square(-10, 20, 510, 21)]
    agents = []
    while len(agents) < n:
        x, y = rng.uniform(0, 500), rng.uniform(0.5, 19.5)
        agents.append((x, y, side(), y))
    write(outdir, "corridor", agents, obs)

    agents = []
    for k in range(4):
        a = k * math.pi / 2
        for _ in range(n // 4):
            u, v = rng.uniform(30, 80), rng.uniform(-25, 25)
            x, y = u * math.cos(a) - v * math.sin(a), u * math.sin(a) + v * math.cos(a)
            agents.append((x, y, -3 * x, -3 * y))
    write(outdir, "crossing", agents, [])

    obs = [square(4 * i + 1.7, 4 * j + 1.7, 4 * i + 2.3, 4 * j + 2.3) for i in range(50) for j in range(50)]
    agents = []
    while len(agents) < n:
        x, y = rng.uniform(0, 200), rng.uniform(0, 200)
        cell = int(x // 4) * 50 + int(y // 4)
        if clear_of(x, y, obs[cell:cell + 1]):
            agents.append((x, y, side(), y))
    write(outdir, "forest", agents, obs)


if __name__ == "__main__":
    main()
