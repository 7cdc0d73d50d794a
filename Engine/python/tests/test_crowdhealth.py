"""The Python module against the program: byte-identical outputs, errors, parameters, arrays,
scenarios built in code, the registry, the docs' example and Examples/python (docs/python.md).

Run through ctest (Engine/python/CMakeLists.txt sets PYTHONPATH, CROWDHEALTH_PROGRAM and
CROWDHEALTH_SOURCE_DIR), or by hand:
    PYTHONPATH=build/python python3 -m pytest Engine/python/tests
"""
import os
import pathlib
import re
import subprocess
import sys

import contextlib
import inspect
import locale
import warnings

from xml.sax.saxutils import quoteattr

import numpy as np
import pytest

import crowdhealth

SRC = pathlib.Path(os.environ.get("CROWDHEALTH_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[3]))
PROGRAM = os.environ.get("CROWDHEALTH_PROGRAM", str(SRC / "build" / "bin" / "crowdhealth"))
ROOM = SRC / "Examples" / "room" / "exit-socialforces-steps.xml"

# A small corridor crossing, written by hand (the builder test rebuilds it in code).
CROSSING_XML = """<?xml version="1.0" encoding="utf-8"?>
<Simulation delta_time="0.1" end_time="6" seed="4">
\t<World type="Planar" xmin="-1" xmax="11" ymin="-1" ymax="5">
\t\t<Box x="0" y="-1" width="10" height="1"/>
\t\t<Obstacle><Point x="0" y="4"/><Point x="10" y="4"/><Point x="10" y="5"/><Point x="0" y="5"/></Obstacle>
\t</World>
\t<Policies>
\t\t<Policy id="0">
\t\t\t<Step DeltaTime="coarse" OptimizationMethod="gradient" RelaxationTime="0.5">
\t\t\t\t<CostFunction name="GoalReachingForce"/>
\t\t\t\t<CostFunction name="SocialForcesAvoidance" range="3"/>
\t\t\t</Step>
\t\t\t<CrowdHealth panicDecay="0.1"/>
\t\t</Policy>
\t</Policies>
\t<Output metrics_interval="0.5"/>
\t<Agents>
\t\t<Agent rad="0.25" pref_speed="1.3"><pos x="1" y="1"/><goal x="9" y="3"/><Policy id="0"/></Agent>
\t\t<Agent rad="0.25"><pos x="1" y="3"/><goal x="9" y="1"/><Policy id="0"/></Agent>
\t\t<Agent rad="0.3"><pos x="9" y="2"/><goal x="1" y="2"/><Policy id="0"/></Agent>
\t\t<Agent><pos x="9" y="1.2345678901"/><goal x="1" y="2.8"/><Policy id="0"/></Agent>
\t</Agents>
</Simulation>
"""


@contextlib.contextmanager
def warnings_as_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error", crowdhealth.ScenarioWarning)
        yield


def crossing_in_code():
    s = crowdhealth.Scenario(delta_time=0.1, end_time=6, seed=4)
    s.world("planar", xmin=-1, xmax=11, ymin=-1, ymax=5)
    s.box(0, -1, 10, 1)
    s.obstacle([(0, 4), (10, 4), (10, 5), (0, 5)])
    s.policy(0, ["GoalReachingForce", ("SocialForcesAvoidance", {"range": 3})], timing="coarse",
             method="gradient", relaxation_time=0.5, crowd_health={"panicDecay": 0.1})
    s.output(metrics_interval=0.5)
    s.agent(1, 1, goal=(9, 3), radius=0.25, pref_speed=1.3)
    s.agent(1, 3, goal=(9, 1), radius=0.25)
    s.agent(9, 2, goal=(1, 2), radius=0.3)
    s.agent(9, 1.2345678901, goal=(1, 2.8))  # every digit reaches the loader
    return s


def run_program(scenario, out, *args):
    r = subprocess.run([PROGRAM, "-i", str(scenario), "-o", str(out), "-q", "-t", "1", *args],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


def test_metrics_csv_byte_identical_to_the_program(tmp_path):
    prog = run_program(ROOM, tmp_path / "prog", "--seed", "3")
    sim = crowdhealth.Simulation(ROOM, seed=3)
    sim.run()
    sim.write_outputs(str(tmp_path / "py"))
    for name in ["metrics.csv", "evacuations.csv", "health.csv", "heatmap.csv"]:
        assert (tmp_path / "py" / name).read_bytes() == (prog / name).read_bytes(), name
    # metrics() holds the same numbers as the file, column by column
    m = sim.metrics()
    assert list(m)[:len(crowdhealth.metrics_columns)] == crowdhealth.metrics_columns
    lines = (prog / "metrics.csv").read_text(encoding="utf-8").splitlines()
    assert lines[0].split(",") == list(m)
    assert len(m["time"]) == len(lines) - 1
    last = lines[-1].split(",")
    # full precision in metrics(); the file rounds time to 10 significant digits
    assert float(last[0]) == float(f'{m["time"][-1]:.10g}') and int(last[2]) == m["evacuated"][-1]
    assert float(last[6]) == float(f'{m["mean_speed"][-1]:.6g}')
    assert m["agents"].dtype == np.int64 and m["mean_speed"].dtype == np.float64


def test_another_seed_gives_another_run_and_threads_do_not_matter(tmp_path):
    a = crowdhealth.Simulation(ROOM, seed=3)
    b = crowdhealth.Simulation(ROOM, seed=5)
    c = crowdhealth.Simulation(ROOM, seed=3, threads=2)
    for s in (a, b, c):
        s.run(until=5)
    assert not np.array_equal(a.positions(), b.positions())
    assert np.array_equal(a.positions(), c.positions())


def test_reading_between_steps_changes_nothing(tmp_path):
    """field("density") measures on demand; stepping by hand equals run()."""
    prog = run_program(ROOM, tmp_path / "prog", "--seed", "2")
    sim = crowdhealth.Simulation(ROOM, seed=2)
    steps = 0
    while sim.step():
        steps += 1
        assert steps < 2000, "step() goes on past the end"
        sim.field("density"), sim.field("contact_accel"), sim.field("panic"), sim.positions()
    assert sim.finished and not sim.step()
    assert steps == sim.steps
    sim.write_outputs(str(tmp_path / "py"))
    assert (tmp_path / "py" / "metrics.csv").read_bytes() == (prog / "metrics.csv").read_bytes()


def test_scenario_error_holds_path_and_line(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text(CROSSING_XML.replace('<Agent rad="0.3">', '<Agent rad="-0.3">'))
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(bad)
    line = CROSSING_XML.splitlines().index(next(l for l in CROSSING_XML.splitlines() if 'rad="0.3"' in l)) + 1
    assert re.search(re.escape(str(bad)) + ":%d: error: .*rad" % line, str(e.value)), str(e.value)
    # the same lines as the program prints
    r = subprocess.run([PROGRAM, "--check", "-i", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2
    first = [l for l in r.stderr.splitlines() if ": error: " in l][0]
    assert first in str(e.value)
    with pytest.raises(crowdhealth.ScenarioError, match="cannot|not|no "):
        crowdhealth.Simulation(tmp_path / "missing.xml")


def test_positions_velocities_ids_and_fields():
    sim = crowdhealth.Simulation(ROOM, seed=1)
    sim.run(until=3.45)  # off the metrics interval (1 s): nothing has measured the density at this step
    assert abs(sim.time - 3.5) < 1e-9
    n = sim.agent_count
    assert 90 < n < 100 and n + sim.evacuated == 100  # the first have left at the exit
    p, v, ids = sim.positions(), sim.velocities(), sim.ids()
    assert p.shape == (n, 2) and p.dtype == np.float64
    assert v.shape == (n, 2) and v.dtype == np.float64
    assert ids.shape == (n,) and ids.dtype == np.int64 and len(set(ids.tolist())) == n
    assert np.all((p[:, 0] > -1) & (p[:, 0] < 16) & (p[:, 1] > -1) & (p[:, 1] < 11))
    for name in ["density", "contact_accel", "panic"]:
        f = sim.field(name)
        assert f.shape == (n,) and f.dtype == np.float64
    rho = sim.field("density")
    assert np.all(rho > 0)  # every agent counts itself
    # the metrics' mean density is the mean of the same per-agent values (the final row, taken at t = 3.5 s)
    sim.end()
    m = sim.metrics()
    assert m["time"][-1] == sim.time
    assert rho.mean() == pytest.approx(m["mean_density"][-1], rel=1e-12)
    assert np.linalg.norm(v, axis=1).mean() == pytest.approx(m["mean_speed"][-1], rel=1e-12)
    assert np.linalg.norm(v, axis=1).max() == pytest.approx(m["max_speed"][-1], rel=1e-12)
    with pytest.raises(ValueError, match="unknown field"):
        sim.field("temperature")


def test_positions_are_the_agents_places(tmp_path):
    path = tmp_path / "crossing.xml"
    path.write_text(CROSSING_XML)
    sim = crowdhealth.Simulation(path)
    assert sim.ids().tolist() == [0, 1, 2, 3]
    assert np.array_equal(sim.positions(), [[1, 1], [1, 3], [9, 2], [9, 1.2345678901]])
    assert np.array_equal(sim.velocities(), np.zeros((4, 2)))
    assert np.array_equal(sim.field("radius"), [0.25, 0.25, 0.3, 0.24])
    sim.run(until=1)
    p, v = sim.positions(), sim.velocities()
    assert np.all(v[:2, 0] > 0.3) and np.all(v[2:, 0] < -0.3)  # walking towards their goals
    sim.step()  # one step of 0.1 s moves each agent by about v dt
    assert np.allclose(sim.positions(), p + 0.1 * v, atol=0.05)


def test_set_parameter_changes_motion(tmp_path):
    path = tmp_path / "crossing.xml"
    path.write_text(CROSSING_XML)
    sims = [crowdhealth.Simulation(path) for _ in range(3)]
    for s in sims:
        s.run(until=1)
    sims[1].set_parameter(0, "GoalReachingForce", "strength", 1.0)  # its value already: no change
    sims[2].set_parameter(None, "GoalReachingForce", "strength", 4.0)
    assert sims[2].parameter(0, "GoalReachingForce", "strength") == 4.0
    for s in sims:
        s.run(until=2)
    assert np.array_equal(sims[0].positions(), sims[1].positions())
    # a stronger drive towards the goal: faster agents
    speed = [np.linalg.norm(s.velocities(), axis=1).mean() for s in sims]
    assert not np.array_equal(sims[0].positions(), sims[2].positions())
    assert speed[2] > speed[0] + 0.01
    # the CrowdHealth layer, addressed as <Ramp component="CrowdHealth"> does
    sims[0].set_parameter(0, "CrowdHealth", "panic", 0.5)
    sims[0].step()
    assert np.all(sims[0].field("panic") >= 0.5 - 1e-12)
    with pytest.raises(ValueError, match="unknown component"):
        sims[0].set_parameter(0, "NoSuchForce", "strength", 1)
    with pytest.raises(ValueError, match="no parameter"):
        sims[0].set_parameter(0, "GoalReachingForce", "strenght", 1)
    with pytest.raises(ValueError, match="out of range"):
        sims[0].set_parameter(0, "GoalReachingForce", "strength", -1)
    with pytest.raises(ValueError, match="targets no component"):
        sims[0].set_parameter(7, "GoalReachingForce", "strength", 1)
    with pytest.raises(ValueError, match="targets no component"):
        sims[0].set_parameter(0, "SPH", "viscosity", 1)


def run_alike(tmp_path, a, b, names):
    """Runs the simulations a and b to their end: the same places at the end, and the files `names`
    the same bytes (written into tmp_path/a and tmp_path/b)."""
    a.run(), b.run()
    assert np.array_equal(a.positions(), b.positions())
    a.write_outputs(str(tmp_path / "a"))
    b.write_outputs(str(tmp_path / "b"))
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_scenario_in_code_equals_the_xml_file(tmp_path):
    path = tmp_path / "crossing.xml"
    path.write_text(CROSSING_XML)
    a = crowdhealth.Simulation(path)
    b = crowdhealth.Simulation(crossing_in_code())
    assert a.agent_count == b.agent_count == 4
    run_alike(tmp_path, a, b, ["metrics.csv", "health.csv", "evacuations.csv"])
    # and the program runs the builder's file to the same metrics
    (tmp_path / "built.xml").write_text(crossing_in_code().to_xml())
    prog = run_program(tmp_path / "built.xml", tmp_path / "prog")
    assert (prog / "metrics.csv").read_bytes() == (tmp_path / "b" / "metrics.csv").read_bytes()


# The crossing with a panic event, safety thresholds and measurement lines and areas, by hand.
CROSSING_MEASURED_XML = CROSSING_XML.replace(
    "\t<Output metrics_interval=\"0.5\"/>\n",
    "\t<Schedule><PanicEvent time=\"2\" x=\"5\" y=\"2\" radius=\"4\" strength=\"0.8\"/></Schedule>\n"
    "\t<Output metrics_interval=\"0.5\"/>\n"
    "\t<Safety cell_size=\"0.5\" density_caution=\"0.3\"/>\n"
    "\t<Measurement interval=\"0.5\">\n"
    "\t\t<Line id=\"middle\" x1=\"5\" y1=\"0\" x2=\"5\" y2=\"4\"/>\n"
    "\t\t<Area id=\"west\" xmin=\"0\" xmax=\"3\" ymin=\"0\" ymax=\"4\"/>\n"
    "\t\t<Area id=\"east\"><Point x=\"7\" y=\"0\"/><Point x=\"10\" y=\"0\"/><Point x=\"10\" y=\"4\"/>"
    "<Point x=\"7\" y=\"4\"/></Area>\n"
    "\t</Measurement>\n")


def crossing_measured_in_code():
    s = crossing_in_code()
    s.panic_event(2, 5, 2, 4, strength=0.8)
    s.safety(cell_size=0.5, density_caution=0.3)
    s.measurement(interval=0.5)
    s.line("middle", 5, 0, 5, 4)
    s.area("west", xmin=0, xmax=3, ymin=0, ymax=4)
    s.area("east", points=[(7, 0), (10, 0), (10, 4), (7, 4)])
    return s


def test_panic_safety_and_measurement_in_code_equal_the_xml_file(tmp_path):
    assert "<PanicEvent" in CROSSING_MEASURED_XML and "<Measurement" in CROSSING_MEASURED_XML
    path = tmp_path / "measured.xml"
    path.write_text(CROSSING_MEASURED_XML)
    a = crowdhealth.Simulation(path)
    b = crowdhealth.Simulation(crossing_measured_in_code())
    run_alike(tmp_path, a, b, ["metrics.csv", "health.csv", "heatmap.csv", "flows.csv", "areas.csv"])
    flows = (tmp_path / "b" / "flows.csv").read_text(encoding="utf-8")
    assert "middle" in flows and "west" in (tmp_path / "b" / "areas.csv").read_text(encoding="utf-8")
    heat = (tmp_path / "b" / "heatmap.csv").read_text(encoding="utf-8").splitlines()
    assert heat[1].split(",")[0] in ("-0.25", "0.25", "0.75")  # half-metre cells: centres at odd quarters
    # the panic event reached someone (the layer records a peak panic)
    health = (tmp_path / "b" / "health.csv").read_text(encoding="utf-8").splitlines()
    col = health[0].split(",").index("peak_panic")
    assert max(float(r.split(",")[col]) for r in health[1:]) >= 0.8
    # and without the three, the run differs (the builder does write them)
    c = crowdhealth.Simulation(crossing_in_code())
    c.run()
    c.write_outputs(str(tmp_path / "c"))
    assert (tmp_path / "c" / "health.csv").read_bytes() != (tmp_path / "b" / "health.csv").read_bytes()
    assert not (tmp_path / "c" / "flows.csv").exists()


def test_safety_and_measurement_errors_name_the_builder_call():
    s = crossing_in_code().safety(cell_size=-1)
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    assert "test_crowdhealth.py:%d:" % (sys._getframe().f_lineno - 3) in str(e.value)
    assert "cell_size" in str(e.value)
    s = crossing_in_code().line("door", 1, 1, 1, 1)  # both ends the same
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    assert "test_crowdhealth.py:%d:" % (sys._getframe().f_lineno - 3) in str(e.value)


# A small venue by hand: a hall with a pillar and two exits in its east wall (an exit set chosen by
# the quickest rule; the north exit closed from 10 s to 20 s), a checkpoint desk on one journey, a
# kiosk where one person stays, a grid of people and a source (the builder test rebuilds it).
VENUE_XML = """<?xml version="1.0" encoding="utf-8"?>
<Simulation delta_time="0.1" end_time="40" seed="3">
\t<World type="Planar" xmin="-1" xmax="21" ymin="-1" ymax="11">
\t\t<Obstacle><Point x="0" y="0"/><Point x="18" y="0"/></Obstacle>
\t\t<Obstacle><Point x="0" y="10"/><Point x="18" y="10"/></Obstacle>
\t\t<Obstacle><Point x="0" y="0"/><Point x="0" y="10"/></Obstacle>
\t\t<Obstacle><Point x="18" y="0"/><Point x="18" y="2"/></Obstacle>
\t\t<Obstacle><Point x="18" y="3.5"/><Point x="18" y="6.5"/></Obstacle>
\t\t<Obstacle><Point x="18" y="8"/><Point x="18" y="10"/></Obstacle>
\t\t<Box x="8" y="4" width="1.5" height="2"/>
\t\t<Navigation cell_size="0.25" clearance="0.4"/>
\t\t<Target id="desk"><Point x="4" y="7"/><Point x="6" y="7"/><Point x="5" y="8.5"/></Target>
\t\t<Target id="kiosk" x="12" y="2.5" radius="0.6"/>
\t\t<Exit id="south" xmin="18.2" xmax="19" ymin="2" ymax="3.5" width="1.5"/>
\t\t<Exit id="north" xmin="18.2" xmax="19" ymin="6.5" ymax="8" width="1.5"/>
\t\t<ExitSet id="east" exits="south north" choice="quickest" interval="1" flow_capacity="1.2"/>
\t\t<Journey id="via-desk" leave_by="east"><Waypoint target="desk" dwell="1" capacity="2"/></Journey>
\t\t<Journey id="out" leave_by="east"/>
\t\t<Journey id="shop"><Waypoint target="kiosk"/></Journey>
\t</World>
\t<Policies>
\t\t<Policy id="0" ContactForceScale="62.5">
\t\t\t<Step DeltaTime="coarse" OptimizationMethod="gradient" RelaxationTime="0.5">
\t\t\t\t<CostFunction name="SocialForcesAvoidance" range="5" R="0.1"/>
\t\t\t\t<CostFunction name="GoalReachingForce"/>
\t\t\t</Step>
\t\t</Policy>
\t</Policies>
\t<Schedule><CloseExit exit="north" time="10"/><OpenExit exit="north" time="20"/></Schedule>
\t<Output metrics_interval="1"/>
\t<Agents>
\t\t<AgentGrid x="1" y="1" columns="4" rows="3" spacing="0.9" rad_min="0.2" rad_max="0.25" journey="via-desk">
\t\t\t<Policy id="0"/>
\t\t</AgentGrid>
\t\t<Agent rad="0.25" journey="shop" premovement="2"><pos x="2" y="5"/><Policy id="0"/></Agent>
\t\t<Source id="door" xmin="1" xmax="3" ymin="3.5" ymax="6" end="8" journey="out" max_speed="2">
\t\t\t<Policy id="0"/><Rate time="0" value="1"/><Rate time="4" value="2"/>
\t\t\t<Draw attribute="pref_speed" distribution="normal" mean="1.3" sd="0.2" min="0.9" max="1.7"/>
\t\t</Source>
\t</Agents>
</Simulation>
"""


def venue_in_code():
    s = crowdhealth.Scenario(delta_time=0.1, end_time=40, seed=3)
    s.world("planar", xmin=-1, xmax=21, ymin=-1, ymax=11)
    for wall in [[(0, 0), (18, 0)], [(0, 10), (18, 10)], [(0, 0), (0, 10)], [(18, 0), (18, 2)], [(18, 3.5), (18, 6.5)],
                 [(18, 8), (18, 10)]]:
        s.obstacle(wall)
    s.box(8, 4, 1.5, 2)
    s.navigation(cell_size=0.25, clearance=0.4)
    s.target("desk", points=[(4, 7), (6, 7), (5, 8.5)])
    s.target("kiosk", x=12, y=2.5, radius=0.6)
    s.exit("south", xmin=18.2, xmax=19, ymin=2, ymax=3.5, width=1.5)
    s.exit("north", xmin=18.2, xmax=19, ymin=6.5, ymax=8, width=1.5)
    s.exit_set("east", ["south", "north"], choice="quickest", interval=1, flow_capacity=1.2)
    s.journey("via-desk", [("desk", 1, 2)], leave_by="east")
    s.journey("out", leave_by="east")
    s.journey("shop", ["kiosk"])
    s.policy(0, [("SocialForcesAvoidance", {"range": 5, "R": 0.1}), "GoalReachingForce"], relaxation_time=0.5,
             contact_force_scale=62.5)
    s.close_exit("north", 10).open_exit("north", 20)
    s.output(metrics_interval=1)
    s.agent_grid(1, 1, 4, 3, spacing=0.9, rad_min=0.2, rad_max=0.25, journey="via-desk")
    s.agent(2, 5, radius=0.25, journey="shop", premovement=2)
    s.source(id="door", xmin=1, xmax=3, ymin=3.5, ymax=6, end=8, journey="out", max_speed=2,
             rates=[(0, 1), (4, 2)],
             draws=[dict(attribute="pref_speed", distribution="normal", mean=1.3, sd=0.2, min=0.9, max=1.7)])
    return s


def test_venue_in_code_equals_the_xml_file(tmp_path):
    path = tmp_path / "venue.xml"
    path.write_text(VENUE_XML)
    with warnings_as_errors():
        a = crowdhealth.Simulation(path)
        b = crowdhealth.Simulation(venue_in_code())
    assert a.agent_count == b.agent_count == 14  # the grid's 12, the shopper, the source's first arrival
    assert a.pending == b.pending > 0  # the source's other arrivals
    run_alike(tmp_path, a, b, ["metrics.csv", "health.csv", "evacuations.csv"])
    # People left by both exits, through the desk's journey and from the source; the one at the
    # kiosk stays.
    rows = (tmp_path / "b" / "evacuations.csv").read_text(encoding="utf-8").splitlines()
    assert b.evacuated >= 15 and b.agent_count >= 1
    assert any(",south" in r for r in rows[1:]) and any(",north" in r for r in rows[1:])
    # and the program runs the builder's file to the same evacuations
    (tmp_path / "built.xml").write_text(venue_in_code().to_xml())
    prog = run_program(tmp_path / "built.xml", tmp_path / "prog")
    assert (prog / "evacuations.csv").read_bytes() == (tmp_path / "b" / "evacuations.csv").read_bytes()


SPAWN_XML = """<?xml version="1.0"?>
<Simulation delta_time="0.05" end_time="11" seed="9">
\t<World type="Planar" xmin="-2" xmax="14" ymin="-2" ymax="8"/>
\t<Policies>
\t\t<Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5">
\t\t\t<costfunction name="GoalReachingForce"/>
\t\t\t<costfunction name="SocialForcesAvoidance" range="3"/>
\t\t</Policy>
\t</Policies>
\t<Agents>
\t\t<SpawnRectangle xmin="0" xmax="2" ymin="0" ymax="6" NrAgentsHorizontal="2" NrAgentsVertical="5" StartTime="0.5"
\t\t\tEndTime="2.5" Interval="1" RemoveAtGoal="true" PositionNoise="0.05" AgentRadius="0.25" AgentRadiusNoise="0.03"
\t\t\tpref_speed="1.2" max_speed="1.6" max_acceleration="4" goal_radius="0.5"><Policy id="0"/><goal x="12" y="3"/></SpawnRectangle>
\t</Agents>
</Simulation>
"""


def test_spawn_rectangle_in_code_equals_the_xml_file(tmp_path):
    path = tmp_path / "spawn.xml"
    path.write_text(SPAWN_XML)
    s = crowdhealth.Scenario(delta_time=0.05, end_time=11, seed=9)
    s.world("planar", xmin=-2, xmax=14, ymin=-2, ymax=8)
    s.policy(0, ["GoalReachingForce", ("SocialForcesAvoidance", {"range": 3})], method="gradient",
             relaxation_time=0.5)
    s.spawn_rectangle(0, 2, 0, 6, columns=2, rows=5, goal=(12, 3), start_time=0.5, end_time=2.5, interval=1,
                      remove_at_goal=True, position_noise=0.05, radius=0.25, radius_noise=0.03, pref_speed=1.2,
                      max_speed=1.6, max_acceleration=4, goal_radius=0.5)
    a, b = crowdhealth.Simulation(path), crowdhealth.Simulation(s)
    # Three waves of ten (0.5, 1.5 and 2.5 s), drawn alike in both.
    a.run(until=1.0), b.run(until=1.0)
    assert a.agent_count == b.agent_count == 10
    run_alike(tmp_path, a, b, ["metrics.csv", "health.csv", "evacuations.csv"])
    assert a.agent_count + a.evacuated == b.agent_count + b.evacuated == 30
    assert 0 < b.evacuated < 30  # the first waves reach the goal and leave


CONCOURSE_DXF = SRC / "Examples" / "venues" / "concourse.dxf"

DRAWING_XML = """<?xml version="1.0"?>
<Simulation delta_time="0.1" end_time="45" seed="4">
\t<World type="Infinite">
\t\t<Obstacles file="%s" scale="0.001">
\t\t\t<Layer name="EXITS" as="exit" prefix="EXIT"/>
\t\t\t<Layer name="GATES" as="target"/>
\t\t\t<Layer name="COUNT" as="line" prefix="DOOR"/>
\t\t\t<Layer name="ZONES" as="area" prefix="FRONT"/>
\t\t\t<Layer name="NOTES" as="ignore"/>
\t\t</Obstacles>
\t\t<Navigation/>
\t\t<ExitSet id="doors" exits="EXIT-1 EXIT-2 EXIT-3" choice="quickest"/>
\t\t<Journey id="through" leave_by="doors"><Waypoint target="GATES-1" dwell="0.5" capacity="4"/></Journey>
\t</World>
\t<Policies>
\t\t<Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
\t\t\t<costfunction name="SocialForcesAvoidance" range="5" R="0.1"/>
\t\t\t<costfunction name="GoalReachingForce"/>
\t\t</Policy>
\t</Policies>
\t<Output metrics_interval="1"/>
\t<Measurement interval="1"><Line id="SECURITY" x1="25" y1="13" x2="25" y2="17"/></Measurement>
\t<Agents>
\t\t<AgentGrid x="16" y="12" columns="4" rows="5" spacing="1.2" rad_min="0.2" rad_max="0.25" pref_speed="1.3"
\t\t\tmax_speed="1.6" journey="through"><Policy id="0"/></AgentGrid>
\t</Agents>
</Simulation>
"""


def drawing_in_code(path=CONCOURSE_DXF, layers=None):
    s = crowdhealth.Scenario(delta_time=0.1, end_time=45, seed=4)
    if layers is None:
        layers = {"EXITS": ("exit", "EXIT"), "GATES": "target", "COUNT": ("line", "DOOR"), "ZONES": ["area", "FRONT"],
                  "NOTES": "ignore"}
    s.obstacles_file(path, scale=0.001, layers=layers)
    s.navigation()
    s.exit_set("doors", ["EXIT-1", "EXIT-2", "EXIT-3"], choice="quickest")
    s.journey("through", [("GATES-1", 0.5, 4)], leave_by="doors")
    s.policy(0, [("SocialForcesAvoidance", {"range": 5, "R": 0.1}), "GoalReachingForce"], method="gradient",
             relaxation_time=0.5, contact_force_scale=62.5)
    s.output(metrics_interval=1)
    s.measurement(interval=1).line("SECURITY", 25, 13, 25, 17)
    s.agent_grid(16, 12, columns=4, rows=5, spacing=1.2, rad_min=0.2, rad_max=0.25, pref_speed=1.3, max_speed=1.6,
                 journey="through")
    return s


def test_a_drawing_in_code_equals_the_xml_file(tmp_path):
    # The walls, exits, checkpoint, lines and areas of Examples/venues/concourse.dxf, named by
    # obstacles_file() and by the file by hand: the same run, byte for byte.
    path = tmp_path / "drawing.xml"
    path.write_text(DRAWING_XML % CONCOURSE_DXF)
    before = locale.setlocale(locale.LC_ALL)
    with warnings_as_errors():
        a = crowdhealth.Simulation(path)
        b = crowdhealth.Simulation(drawing_in_code())
    assert a.agent_count == b.agent_count == 20
    assert locale.setlocale(locale.LC_ALL) == before  # reading the drawing left Python's locale alone
    run_alike(tmp_path, a, b, ["metrics.csv", "health.csv", "evacuations.csv", "flows.csv", "areas.csv"])
    flows = (tmp_path / "b" / "flows.csv").read_text(encoding="utf-8")
    assert "DOOR-1" in flows and "SECURITY" in flows  # lines from the drawing's layer and from code
    assert "FRONT-1" in (tmp_path / "b" / "areas.csv").read_text(encoding="utf-8")
    assert b.evacuated > 0
    # The layers as a list of tuples say the same; a relative path is taken from the current directory.
    layers = [("EXITS", "exit", "EXIT"), ("GATES", "target"), ("COUNT", "line", "DOOR"), ("ZONES", "area", "FRONT"),
              ("NOTES", "ignore")]
    here = os.getcwd()
    try:
        os.chdir(CONCOURSE_DXF.parent)
        text = drawing_in_code("concourse.dxf", layers).to_xml()
    finally:
        os.chdir(here)
    assert text == drawing_in_code().to_xml()
    assert 'file=%s' % quoteattr(str(CONCOURSE_DXF)) in text


def test_drawing_errors_name_the_builder_call(tmp_path):
    s = drawing_in_code(tmp_path / "missing.dxf")
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    lines, first = inspect.getsourcelines(drawing_in_code)
    call = first + next(k for k, line in enumerate(lines) if "s.obstacles_file(" in line)
    assert "test_crowdhealth.py:%d:" % call in str(e.value)  # the obstacles_file() call
    assert "missing.dxf" in str(e.value)
    s = drawing_in_code(layers={"EXITS": "exit", "WALLS": "doorway"})
    with pytest.raises(crowdhealth.ScenarioError, match="doorway"):
        crowdhealth.Simulation(s)
    with pytest.raises(ValueError, match="EXITS"):
        drawing_in_code(layers=[("EXITS", "exit", "EXIT", "extra")])


FILES_XML = """<?xml version="1.0"?>
<Simulation delta_time="0.1" end_time="12" seed="3">
\t<World type="Infinite"/>
\t<Policies file="policies.xml"/>
\t<Policies>
\t\t<Policy id="1" OptimizationMethod="gradient" RelaxationTime="0.5">
\t\t\t<costfunction name="GoalReachingForce"/>
\t\t\t<costfunction name="SocialForcesAvoidance" range="3"/>
\t\t</Policy>
\t</Policies>
\t<Agents file="agents.xml"/>
\t<Agents>
\t\t<Agent id="7" rad="0.25" pref_speed="1.1"><pos x="9" y="0.2"/><goal x="-1" y="0.2"/><Policy id="1"/></Agent>
\t</Agents>
</Simulation>
"""

POLICIES_FILE = """<Policies>
\t<Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5">
\t\t<costfunction name="GoalReachingForce"/>
\t\t<costfunction name="SocialForcesAvoidance" range="5"/>
\t</Policy>
</Policies>
"""

AGENTS_FILE = """<Agents>
\t<Agent id="1" rad="0.25"><pos x="0" y="0"/><goal x="10" y="0"/><Policy id="0"/></Agent>
\t<Agent id="2" rad="0.25"><pos x="0" y="1"/><goal x="10" y="1"/><Policy id="0"/></Agent>
</Agents>
"""


def test_policies_and_agents_files_in_code_equal_the_xml_file(tmp_path):
    # <Policies file> and <Agents file> beside policies and agents given in code: the files' come
    # first (agents are numbered in that order), as in the scenario written by hand.
    (tmp_path / "policies.xml").write_text(POLICIES_FILE)
    (tmp_path / "agents.xml").write_text(AGENTS_FILE)
    (tmp_path / "files.xml").write_text(FILES_XML)
    here = os.getcwd()
    try:
        os.chdir(tmp_path)  # relative paths: from the current directory
        s = crowdhealth.Scenario(delta_time=0.1, end_time=12, seed=3)
        s.policies_file("policies.xml").agents_file("agents.xml")
    finally:
        os.chdir(here)
    s.policy(1, ["GoalReachingForce", ("SocialForcesAvoidance", {"range": 3})], relaxation_time=0.5)
    s.agent(9, 0.2, goal=(-1, 0.2), policy=1, id=7, radius=0.25, pref_speed=1.1)
    with warnings_as_errors():
        a = crowdhealth.Simulation(tmp_path / "files.xml")
        b = crowdhealth.Simulation(s)
    assert list(a.ids()) == list(b.ids()) == [1, 2, 7]
    run_alike(tmp_path, a, b, ["metrics.csv", "health.csv", "evacuations.csv"])
    assert 'file=%s' % quoteattr(str(tmp_path / "policies.xml")) in s.to_xml()
    # A file that is not there is an error at the call that named it.
    s = crowdhealth.Scenario().agents_file(tmp_path / "nobody.xml").policy(0, ["GoalReachingForce"])
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    assert "test_crowdhealth.py:%d:" % (sys._getframe().f_lineno - 3) in str(e.value)
    assert "nobody.xml" in str(e.value)


def test_venue_errors_name_the_builder_call():
    s = venue_in_code().exit_set("west", ["south", "nowhere"])
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    assert "test_crowdhealth.py:%d:" % (sys._getframe().f_lineno - 3) in str(e.value)
    assert "nowhere" in str(e.value)
    s = venue_in_code().source(xmin=1, xmax=3, ymin=3.5, ymax=6, count=5, rates=[(0, -1)])
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    assert "test_crowdhealth.py:%d:" % (sys._getframe().f_lineno - 3) in str(e.value)


def test_scenario_in_code_is_checked_by_the_loader():
    s = crossing_in_code()
    s.agent(5, 2, goal=(1, 1), policy=3)  # no policy 3
    with pytest.raises(crowdhealth.ScenarioError) as e:
        crowdhealth.Simulation(s)
    msg = str(e.value)
    assert "policy 3 does not exist" in msg
    assert "test_crowdhealth.py:%d:" % (sys._getframe().f_lineno - 5) in msg  # the builder call's line
    s = crowdhealth.Scenario().policy(0, [("GoalReachingForce", {"strength": -2})]).agent(0, 0, goal=(1, 0))
    with pytest.raises(crowdhealth.ScenarioError, match="strength"):
        crowdhealth.Simulation(s)


def test_verdict_and_outputs_match_summary_json(tmp_path):
    import json
    sim = crowdhealth.Simulation(ROOM, seed=1)
    sim.run()
    v = sim.verdict()
    assert v["level"] in ("safe", "caution", "dangerous", "critical") and isinstance(v["reasons"], list)
    sim.write_outputs(str(tmp_path / "out"))
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert summary["verdict"] == v
    prog = run_program(ROOM, tmp_path / "prog", "--seed", "1")
    assert json.loads((prog / "summary.json").read_text(encoding="utf-8"))["verdict"] == v
    with pytest.raises(RuntimeError, match="ended"):
        sim.step()
    # the program's folder rules: a folder with someone else's file is refused
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    sim2 = crowdhealth.Simulation(ROOM, seed=1)
    sim2.run(until=1)
    with pytest.raises(RuntimeError, match="notes.txt"):
        sim2.write_outputs(str(other))


def test_list_policies_names_the_registered_components():
    listed = crowdhealth.list_policies()
    names = [p["name"] for p in listed]
    r = subprocess.run([PROGRAM, "--list-policies"], capture_output=True, text=True, check=True)
    program_names = re.findall(r"^(\w+)  \[(?:force|cost function)\]$", r.stdout, re.M)
    assert names == program_names and len(names) >= 10
    goal = listed[names.index("GoalReachingForce")]
    assert goal["kind"] == "force"
    assert [q["name"] for q in goal["parameters"]] == ["coeff", "range", "strength"]


def _python_env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in [str(pathlib.Path(crowdhealth.__file__).parents[1]),
                                                      env.get("PYTHONPATH", "")] if p)
    env["MPLBACKEND"] = "Agg"
    return env


def test_the_docs_example_runs(tmp_path):
    text = (SRC / "docs" / "python.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- example: run by Engine/python/tests -->\s*```python\n(.*?)```", text, re.S)
    assert m, "docs/python.md lost its complete example"
    (tmp_path / "example.py").write_text(m.group(1))
    r = subprocess.run([sys.executable, "example.py", str(SRC)], cwd=tmp_path, env=_python_env(),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "out" / "metrics.csv").exists()


def docs_block(name):
    """Runs the code block of docs/python.md marked `<!-- NAME example: run by Engine/python/tests -->`
    as written there (no scenario warning allowed) and returns its variables."""
    text = (SRC / "docs" / "python.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- %s example: run by Engine/python/tests -->\s*```python\n(.*?)```" % name, text, re.S)
    assert m, "docs/python.md lost its %s example" % name
    scope = {"np": np, "crowdhealth": crowdhealth}
    with warnings_as_errors():
        exec(m.group(1), scope)
    return scope


def test_the_docs_builder_example_loads_and_runs(tmp_path):
    # The Scenario block of docs/python.md, as written there (its ramp once named a parameter that
    # cannot be ramped, and the page's example went on being refused unnoticed).
    sim = docs_block("builder")["sim"]
    sim.run()
    sim.write_outputs(str(tmp_path / "out"))
    for name in ["metrics.csv", "heatmap.csv", "flows.csv", "areas.csv"]:
        assert (tmp_path / "out" / name).exists(), name
    # everyone walks east through the line "middle" (forward: towards its right-hand side, east)
    rows = [r.split(",") for r in (tmp_path / "out" / "flows.csv").read_text(encoding="utf-8").splitlines()[1:]]
    assert sum(int(r[3]) for r in rows if r[1] == "middle") == 3
    assert sum(int(r[4]) for r in rows if r[1] == "middle") == 0


def test_the_docs_venue_example_loads_and_runs(tmp_path):
    sim = docs_block("venue")["venue"]
    assert sim.agent_count == 21 and sim.pending > 0  # the grid's 20 and the source's first arrival
    sim.run()
    sim.write_outputs(str(tmp_path / "out"))
    rows = (tmp_path / "out" / "evacuations.csv").read_text(encoding="utf-8").splitlines()[1:]
    assert sim.evacuated == len(rows) == 35 and sim.agent_count == 0  # the grid's 20 and 15 arrivals, all out
    assert any(",south" in r for r in rows) and any(",north" in r for r in rows)


@pytest.mark.parametrize("example", sorted(p.name for p in (SRC / "Examples" / "python").glob("*.py")))
def test_examples_run(tmp_path, example):
    r = subprocess.run([sys.executable, str(SRC / "Examples" / "python" / example), "--out", str(tmp_path)],
                       cwd=tmp_path, env=_python_env(), capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


def test_warnings_are_scenario_warnings():
    s = crowdhealth.Scenario()  # no end time: the program warns that the run ends when everyone has left
    s.policy(0, ["GoalReachingForce"]).agent(0, 0, goal=(2, 0), remove_at_goal=True)
    with pytest.warns(crowdhealth.ScenarioWarning, match="no end_time"):
        sim = crowdhealth.Simulation(s)
    assert "no end_time" in sim.warnings
    sim.run()
    assert sim.agent_count == 0 and sim.evacuated == 1 and 1 < sim.time < 3


def test_a_plugin_force_loads_and_runs(tmp_path):
    """Examples/plugin's DistancingForce through crowdhealth.load_plugin: listed, and two walkers
    1 m apart are pushed to its distance (1.5 m); a missing file raises ScenarioError."""
    plugin = os.environ.get("CROWDHEALTH_EXAMPLE_PLUGIN", str(SRC / "build" / "plugins" / "libdistancing.so"))
    assert crowdhealth.load_plugin(plugin) in (["DistancingForce"], [])  # [] when loaded before
    assert crowdhealth.load_plugin(plugin) == []
    entry = [c for c in crowdhealth.list_policies() if c["name"] == "DistancingForce"]
    assert len(entry) == 1 and entry[0]["plugin"] == os.path.realpath(plugin)
    assert [p["name"] for p in entry[0]["parameters"]] == ["coeff", "range", "distance", "strength"]
    agents = "".join(
        f'<Agent id="{k}" rad="0.25" pref_speed="1.2"><pos x="0" y="{y}"/><goal x="100" y="{y}"/><Policy id="0"/></Agent>'
        for k, y in enumerate((0.5, -0.5)))
    scenario = tmp_path / "walkers.xml"
    scenario.write_text(
        '<Simulation delta_time="0.1" end_time="10"><World type="Infinite"/>'
        '<Policies><Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5">'
        '<costfunction name="GoalReachingForce"/><costfunction name="DistancingForce" distance="1.5"/>'
        f'</Policy></Policies><Agents>{agents}</Agents></Simulation>')
    sim = crowdhealth.Simulation(str(scenario))
    sim.run()
    p = sim.positions()
    assert 1.49 < np.hypot(*(p[0] - p[1])) < 1.6
    with pytest.raises(crowdhealth.ScenarioError, match="no such file"):
        crowdhealth.load_plugin(str(tmp_path / "nothing.so"))
