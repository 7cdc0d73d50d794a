"""Changing a parameter mid-run: a room with 64 people (built in code, with the CrowdHealth layer
in its policy) runs twice with the same seed; in the second run, at t = 5 s, everyone is scared:
the layer's scheduled panic floor goes to 0.8 (as <Ramp component="CrowdHealth" parameter="panic">
would set it), which raises the preferred speed towards the layer's panic speed. Prints the mean
speed and the people out every 5 s for both runs, and writes the scared run's outputs.

    PYTHONPATH=build/python python3 Examples/python/change_parameter.py [--out DIR]
"""
import argparse
import pathlib

import numpy as np

import crowdhealth


def room():
    s = crowdhealth.Scenario(delta_time=0.1, delta_time_fine=0.05, end_time=120, seed=3)
    s.world("planar", xmin=-2, xmax=12, ymin=-2, ymax=10)
    s.box(-1, -1, 1, 10).box(0, -1, 8, 1).box(0, 8, 8, 1).box(8, -1, 1, 4.2).box(8, 4.8, 1, 4.2)  # 1.2 m exit
    s.policy(0, ["GoalReachingForce"], timing="coarse", relaxation_time=0.5, crowd_health={})
    s.step(0, [("SocialForcesAvoidance", {"range": 3})], timing="fine", relaxation_time=0.5)
    grid = np.array([(0.6 + i, 0.6 + j) for i in range(8) for j in range(8)]) * 0.85
    s.agents(grid, goal=(10, 4.5), remove_at_goal=True, goal_radius=0.5, pref_speed=1.0)
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".", help="folder for the outputs of the scared run (scared/)")
    out = pathlib.Path(ap.parse_args().out)
    calm = crowdhealth.Simulation(room())
    scared = crowdhealth.Simulation(room())
    print("   t    calm: speed  out    scared: speed  out  panic")
    for t in range(5, 120, 5):
        if calm.finished and scared.finished:
            break
        calm.run(until=t)
        scared.run(until=t)
        if t == 5:
            scared.set_parameter(None, "CrowdHealth", "panic", 0.8)  # None: every policy that has the layer
        line = "%4d   " % t
        for sim in (calm, scared):
            speed = sim.field("speed")
            line += "%12.2f %4d   " % (speed.mean() if len(speed) else 0.0, sim.evacuated)
        panic = scared.field("panic")
        print(line + "%5.2f" % (panic.mean() if len(panic) else 0.0))
    for sim in (calm, scared):
        sim.run()
    print("everyone out at %.1f s (calm) and %.1f s (scared)" % (calm.summary()["evacuation_time"],
                                                                 scared.summary()["evacuation_time"]))
    scared.write_outputs(str(out / "scared"), overwrite=True)
    print("the scared run's outputs (metrics.csv ...) in", out / "scared")


if __name__ == "__main__":
    main()
