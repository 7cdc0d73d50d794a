"""CrowdHealth from Python (docs/python.md).

    import crowdhealth
    sim = crowdhealth.Simulation("Examples/doorway/base-case.xml", seed=1)
    sim.run(until=10)
    xy = sim.positions()          # N x 2 float64, in the order of sim.ids()
    sim.run()
    sim.write_outputs("out")      # metrics.csv ... as `crowdhealth -i ... -o out` writes them

A scenario can also be built in code with Scenario (no XML file to write); it is checked by the
program's own loader, so it is accepted or refused exactly as the same scenario in a file.
"""
import inspect
import os
import re
import tempfile
from xml.sax.saxutils import quoteattr

from ._crowdhealth import ScenarioError, ScenarioWarning, list_policies, load_plugin, metrics_columns
from ._crowdhealth import Simulation as _Simulation

__all__ = ["Simulation", "Scenario", "ScenarioError", "ScenarioWarning", "list_policies", "load_plugin", "metrics_columns"]


def _number(v):
    """A number as the loader reads it back exactly (repr is the shortest round-trip text)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    return str(v)


def _attrs(d):
    return "".join(" %s=%s" % (k, quoteattr(_number(v))) for k, v in d.items() if v is not None)


def _points(points):
    """<Point x y/> children of a polygon: a list of (x, y) in m."""
    return "".join("<Point%s/>" % _attrs(dict(x=float(x), y=float(y))) for x, y in points)


def _goal(goal):
    """A <goal x y/> child for goal (x, y), or nothing for None."""
    return "" if goal is None else "<goal%s/>" % _attrs(dict(x=float(goal[0]), y=float(goal[1])))


def _policy(policy):
    """The <Policy id/> child of an agent or a group of agents."""
    return "<Policy%s/>" % _attrs(dict(id=policy))


def _place(tag, id, x, y, radius, xmin, xmax, ymin, ymax, points, extra):
    """A <Target> or <Exit> element: a point, a rectangle or a polygon (points)."""
    attrs = _attrs(dict(id=id, x=x, y=y, radius=radius, xmin=xmin, xmax=xmax, ymin=ymin, ymax=ymax, **extra))
    if points is None:
        return "<%s%s/>" % (tag, attrs)
    return "<%s%s>%s</%s>" % (tag, attrs, _points(points), tag)


def _absolute(path):
    """A file named to the builder, from the current directory (the scenario it writes lives in a
    temporary folder, so it names files by their absolute paths)."""
    return os.path.abspath(os.fspath(path))


def _caller():
    """file:line of the user's call into the builder (for error messages)."""
    here = os.path.dirname(os.path.abspath(__file__))
    for frame in inspect.stack()[2:]:
        if os.path.dirname(os.path.abspath(frame.filename)) != here:
            return "%s:%d" % (frame.filename, frame.lineno)
    return "?"


class Scenario:
    """A scenario built in code: world, obstacles, venues (navigation, targets, exits, journeys),
    policies with their parameters, agents (one by one, grids, sources), schedule and outputs.

    Every method returns the Scenario, so calls chain. Pass it to Simulation() in place of a path.
    The loader checks it when the Simulation is made: a bad value raises ScenarioError naming the
    builder call (file:line) that gave it.
    """

    def __init__(self, delta_time=0.1, delta_time_fine=None, end_time=None, seed=1, symmetry_breaking=None,
                 name="scenario built in Python"):
        self.name = name
        self._sim = dict(delta_time=delta_time, delta_time_fine=delta_time_fine, end_time=end_time, seed=seed,
                         symmetry_breaking=symmetry_breaking)
        self._world = ("Infinite", {})
        self._obstacles = []   # (xml, origin)
        self._policies = {}    # id -> [attrs, [steps], crowd_health or None, origin]
        self._agents = []      # (xml, origin)
        self._files = {"Policies": [], "Agents": []}  # (xml, origin) of <Policies file>, <Agents file>
        self._output = {}
        self._ramps = []       # (xml, origin): <Ramp>, <PanicEvent>, <CloseExit>, <OpenExit>, in the order given
        self._safety = None    # (xml, origin)
        self._measurement = None  # [attrs, origin] of <Measurement>, or None
        self._measures = []    # (xml, origin): its <Line> and <Area> children
        self._navigation = None  # (xml, origin) of <Navigation>, or None
        self._venue = []       # (xml, origin): <Target>, <Exit>, <ExitSet>, <Journey>, in the order given

    # ---- world and obstacles ----------------------------------------------------------------
    def world(self, type="infinite", width=None, height=None, xmin=None, xmax=None, ymin=None, ymax=None):
        """type: "infinite", "toric" (width, height) or "planar" (xmin, xmax, ymin, ymax)."""
        kind = {"infinite": "Infinite", "toric": "Toric", "planar": "Planar"}.get(str(type).lower())
        if kind is None:
            raise ValueError("world type must be infinite, toric or planar, not %r" % (type,))
        self._world = (kind, dict(width=width, height=height, xmin=xmin, xmax=xmax, ymin=ymin, ymax=ymax), _caller())
        return self

    def obstacle(self, points):
        """A closed polygon: a list of (x, y) in m."""
        self._obstacles.append(("<Obstacle>%s</Obstacle>" % _points(points), _caller()))
        return self

    def box(self, x, y, width, height):
        """An axis-aligned rectangle with its lower-left corner at (x, y) (UMANS' <Box>)."""
        self._obstacles.append(("<Box%s/>" % _attrs(dict(x=x, y=y, width=width, height=height)), _caller()))
        return self

    def obstacles_file(self, path, scale=None, layers=None):
        """<Obstacles file>: the walls (and, from a DXF drawing's layers, exits, targets and
        measurement lines and areas) of a drawing or a plan made elsewhere: a DXF drawing (.dxf),
        a WKT walkable area (.wkt) or an XML file whose top-level <Obstacles> holds them.

        path: relative paths are taken from the current directory (the written scenario names the
        file by its absolute path). scale: metres per drawing unit (.dxf and .wkt only; 0.001 for
        millimetres). layers (.dxf only): how its layers are read, as a dict {layer: as} or
        {layer: (as, prefix)}, or a list of (layer, as) and (layer, as, prefix); `as` is wall,
        boundary, exit, target, line, area or ignore (docs/xml-reference.md, <Layer>)."""
        entries = layers.items() if isinstance(layers, dict) else ((item[0], item[1:]) for item in layers or [])
        children = ""
        for name, how in entries:
            how = tuple(how) if isinstance(how, (tuple, list)) else (how,)
            if len(how) not in (1, 2):
                raise ValueError("layer %r: give its role and at most a prefix, not %r" % (name, how))
            children += "<Layer%s/>" % _attrs(dict(name=name, **{"as": how[0]},
                                                    prefix=how[1] if len(how) > 1 else None))
        attrs = _attrs(dict(file=_absolute(path), scale=scale))
        xml = "<Obstacles%s>%s</Obstacles>" % (attrs, children) if children else "<Obstacles%s/>" % attrs
        self._obstacles.append((xml, _caller()))
        return self

    # ---- venues (docs/navigation.md) ---------------------------------------------------------
    def navigation(self, cell_size=None, clearance=None, min_speed=None, margin=None):
        """<Navigation>: agents follow the shortest walkable path to their target (a distance field
        per target) instead of walking straight at it. A second call replaces the first."""
        self._navigation = ("<Navigation%s/>" % _attrs(dict(cell_size=cell_size, clearance=clearance,
                                                              min_speed=min_speed, margin=margin)), _caller())
        return self

    def target(self, id, x=None, y=None, radius=None, xmin=None, xmax=None, ymin=None, ymax=None, points=None):
        """<Target>: a named place, one shape of three: a point (x, y; reached within radius), a
        rectangle (xmin, xmax, ymin, ymax) or a polygon (points: a list of (x, y))."""
        self._venue.append((_place("Target", id, x, y, radius, xmin, xmax, ymin, ymax, points, {}), _caller()))
        return self

    def exit(self, id, x=None, y=None, radius=None, xmin=None, xmax=None, ymin=None, ymax=None, points=None,
             width=None):
        """<Exit>: a target where people leave the simulation (shapes as target()); width is its
        clear width in m (the quickest rule's capacity)."""
        self._venue.append((_place("Exit", id, x, y, radius, xmin, xmax, ymin, ymax, points, dict(width=width)),
                            _caller()))
        return self

    def exit_set(self, id, exits, choice=None, weights=None, fixed=None, interval=None, hysteresis=None,
                 flow_capacity=None):
        """<ExitSet>: the exits (a list of exit ids) an agent may leave by and the rule that picks
        one: choice "nearest", "quickest", "fixed" (the exit `fixed`) or "weighted" (weights: one
        number per exit)."""
        names = exits if isinstance(exits, str) else " ".join(str(e) for e in exits)
        w = weights if weights is None or isinstance(weights, str) else " ".join(_number(float(v)) for v in weights)
        self._venue.append(("<ExitSet%s/>" % _attrs(dict(id=id, exits=names, choice=choice, weights=w, fixed=fixed,
                                                          interval=interval, hysteresis=hysteresis,
                                                          flow_capacity=flow_capacity)), _caller()))
        return self

    def journey(self, id, waypoints=(), leave_by=None):
        """<Journey>: the waypoints in order, then leave by an exit or exit set (leave_by, its id).
        A waypoint is a target id, or (target, dwell) or (target, dwell, capacity): dwell s spent
        inside it, at most `capacity` people inside at once (a checkpoint)."""
        parts = []
        for w in waypoints:
            if isinstance(w, str):
                w = (w,)
            target, dwell, capacity = (tuple(w) + (None, None))[:3]
            parts.append("<Waypoint%s/>" % _attrs(dict(target=target, dwell=dwell, capacity=capacity)))
        attrs = _attrs(dict(id=id, leave_by=leave_by))
        xml = ("<Journey%s>%s</Journey>" % (attrs, "".join(parts))) if parts else "<Journey%s/>" % attrs
        self._venue.append((xml, _caller()))
        return self

    # ---- policies ---------------------------------------------------------------------------
    def policies_file(self, path):
        """<Policies file>: the policies of an XML file whose top-level <Policies> holds them (as
        UMANS' examples keep theirs), read before those given in code. A relative path is taken
        from the current directory."""
        return self._file("Policies", path)

    def agents_file(self, path):
        """<Agents file>: the agents of an XML file whose top-level <Agents> holds them, placed
        before those given in code (agents are numbered in that order). A relative path is taken
        from the current directory."""
        return self._file("Agents", path)

    def _file(self, block, path):
        self._files[block].append(("<%s%s/>" % (block, _attrs(dict(file=_absolute(path)))), _caller()))
        return self

    def policy(self, id, components, timing="coarse", method="gradient", relaxation_time=None,
               contact_force_scale=None, crowd_health=None, **step_options):
        """A policy with one step. components: list of names, (name, params) or (name, coeff, params),
        where params is a dict of the component's parameters (crowdhealth.list_policies() lists them).
        timing: "coarse" or "fine"; method: "gradient", "sampling" or "global".
        crowd_health: None (the layer measures with its defaults) or a dict of <CrowdHealth> parameters.
        More steps: step(id, ...)."""
        if id in self._policies:
            raise ValueError("policy %d is defined already" % id)
        self._policies[id] = [dict(id=id, ContactForceScale=contact_force_scale), [], crowd_health, _caller()]
        self._add_step(id, components, timing, method, relaxation_time, step_options, _caller())
        return self

    def step(self, policy, components, timing="coarse", method="gradient", relaxation_time=None, **step_options):
        """Adds another step to a policy (evaluated in order, UMANS' <Step>)."""
        if policy not in self._policies:
            raise ValueError("policy %d is not defined (call policy() first)" % policy)
        self._add_step(policy, components, timing, method, relaxation_time, step_options, _caller())
        return self

    def _add_step(self, policy, components, timing, method, relaxation_time, options, origin):
        parts = []
        for c in components:
            if isinstance(c, str):
                name, coeff, params = c, None, {}
            elif len(c) == 2:
                name, coeff, params = c[0], None, c[1]
            else:
                name, coeff, params = c
            parts.append("<CostFunction%s/>" % _attrs(dict(name=name, coeff=coeff, **params)))
        attrs = dict(DeltaTime=timing, OptimizationMethod=method, RelaxationTime=relaxation_time, **options)
        self._policies[policy][1].append(("<Step%s>%s</Step>" % (_attrs(attrs), "".join(parts)), origin))

    # ---- agents -----------------------------------------------------------------------------
    def agent(self, x, y, goal=None, policy=0, id=None, radius=None, pref_speed=None, max_speed=None,
              max_acceleration=None, mass=None, remove_at_goal=None, goal_radius=None, start_time=None, group=None,
              journey=None, premovement=None):
        """One agent at (x, y) m walking to goal (x, y), or following a journey (its id), with the
        given policy id."""
        attrs = dict(id=id, rad=radius, pref_speed=pref_speed, max_speed=max_speed, max_acceleration=max_acceleration,
                     mass=mass, remove_at_goal=remove_at_goal, goal_radius=goal_radius, start_time=start_time,
                     group=group, journey=journey, premovement=premovement)
        inner = "<pos%s/>" % _attrs(dict(x=float(x), y=float(y)))
        inner += _goal(goal)
        inner += _policy(policy)
        self._agents.append(("<Agent%s>%s</Agent>" % (_attrs(attrs), inner), _caller()))
        return self

    def agents(self, positions, goal=None, **attributes):
        """Several agents (positions: an iterable of (x, y), e.g. an N x 2 numpy array) with the same
        goal and attributes (those of agent())."""
        for x, y in positions:
            self.agent(float(x), float(y), goal=goal, **attributes)
        return self

    def agent_grid(self, x, y, columns, rows, spacing=None, goal=None, policy=0, rad_min=None, rad_max=None,
                   pref_speed=None, max_speed=None, max_acceleration=None, remove_at_goal=None, goal_radius=None,
                   start_time=None, premovement=None, journey=None, group_size=None):
        """<AgentGrid>: columns x rows agents from (x, y) m, `spacing` m apart, radii drawn from
        [rad_min, rad_max] by the run's seed; they walk to goal (x, y) or follow a journey."""
        attrs = dict(x=x, y=y, columns=columns, rows=rows, spacing=spacing, rad_min=rad_min, rad_max=rad_max,
                     pref_speed=pref_speed, max_speed=max_speed, max_acceleration=max_acceleration,
                     remove_at_goal=remove_at_goal, goal_radius=goal_radius, start_time=start_time,
                     premovement=premovement, journey=journey, group_size=group_size)
        inner = _policy(policy) + _goal(goal)
        self._agents.append(("<AgentGrid%s>%s</AgentGrid>" % (_attrs(attrs), inner), _caller()))
        return self

    def spawn_rectangle(self, xmin, xmax, ymin, ymax, columns, rows, goal=None, policy=0, start_time=None,
                        end_time=None, interval=None, remove_at_goal=None, position_noise=None, radius=None,
                        radius_noise=None, pref_speed=None, max_speed=None, max_acceleration=None,
                        goal_radius=None):
        """<SpawnRectangle> (SPH-era UMANS): columns x rows agents, one at the centre of each cell of
        the rectangle, at start_time s and then every `interval` s until end_time s (interval 0 or
        None: once); position_noise and radius_noise m of uniform noise drawn from the run's seed,
        radius the agents' radius (XML: AgentRadius)."""
        attrs = dict(xmin=xmin, xmax=xmax, ymin=ymin, ymax=ymax, NrAgentsHorizontal=columns, NrAgentsVertical=rows,
                     StartTime=start_time, EndTime=end_time, Interval=interval, RemoveAtGoal=remove_at_goal,
                     PositionNoise=position_noise, AgentRadius=radius, AgentRadiusNoise=radius_noise,
                     pref_speed=pref_speed, max_speed=max_speed, max_acceleration=max_acceleration,
                     goal_radius=goal_radius)
        inner = _policy(policy) + _goal(goal)
        self._agents.append(("<SpawnRectangle%s>%s</SpawnRectangle>" % (_attrs(attrs), inner), _caller()))
        return self

    def source(self, policy=0, id=None, xmin=None, xmax=None, ymin=None, ymax=None, points=None, goal=None,
               rates=None, draws=None, **attributes):
        """<Source>: agents appearing over time in a rectangle (xmin, xmax, ymin, ymax) or polygon
        (points). rates: a list of (time, value) (arrivals per second from that time on; else the
        `rate` attribute); draws: a list of dicts of <Draw> attributes (attribute, distribution,
        value, min, max, mean, sd, mu, sigma). Other attributes by their XML names: rate, start,
        end, count, journey, rad, pref_speed, max_speed, premovement, max_acceleration,
        remove_at_goal, group_size_min, group_size_max, group_share."""
        attrs = dict(id=id, xmin=xmin, xmax=xmax, ymin=ymin, ymax=ymax, **attributes)
        inner = _policy(policy) + _goal(goal)
        if points is not None:
            inner += _points(points)
        for time, value in rates or ():
            inner += "<Rate%s/>" % _attrs(dict(time=time, value=value))
        for d in draws or ():
            inner += "<Draw%s/>" % _attrs(d)
        self._agents.append(("<Source%s>%s</Source>" % (_attrs(attrs), inner), _caller()))
        return self

    # ---- schedule and output ----------------------------------------------------------------
    def close_exit(self, exit, time):
        """<CloseExit>: the exit (its id) closes at `time` s; everyone leaving re-chooses."""
        self._ramps.append(("<CloseExit%s/>" % _attrs(dict(exit=exit, time=time)), _caller()))
        return self

    def open_exit(self, exit, time):
        """<OpenExit>: the exit (its id) opens (again) at `time` s."""
        self._ramps.append(("<OpenExit%s/>" % _attrs(dict(exit=exit, time=time)), _caller()))
        return self

    def ramp(self, component, parameter, start_value, end_value, start, end, policy=None):
        """<Ramp>: moves component.parameter from start_value (at `start` s) to end_value (at `end`)."""
        self._ramps.append(("<Ramp%s/>" % _attrs(dict(component=component, policy=policy, parameter=parameter,
                                                        **{"from": start_value, "to": end_value},
                                                        start=start, end=end)), _caller()))
        return self

    def panic_event(self, time, x, y, radius, strength=None):
        """<PanicEvent>: at `time` (s) every agent within `radius` (m) of (x, y) panics at least
        `strength` (0..1, default 1); needs a policy with crowd_health to change motion."""
        self._ramps.append(("<PanicEvent%s/>" % _attrs(dict(time=time, x=x, y=y, radius=radius, strength=strength)),
                            _caller()))
        return self

    # ---- safety and measurement -------------------------------------------------------------
    def safety(self, **thresholds):
        """<Safety>: the safety recorder's grid and the verdict's thresholds, by their XML names
        (cell_size, density_caution, density_dangerous, ...; docs/xml-reference.md lists them).
        A second call replaces the first."""
        self._safety = ("<Safety%s/>" % _attrs(thresholds), _caller())
        return self

    def measurement(self, interval=None):
        """<Measurement>: the interval (s) of flows.csv and areas.csv rows; line() and area() add
        to it (they open it with the default interval when this is not called)."""
        self._measurement = [dict(interval=interval), _caller()]
        return self

    def line(self, id, x1, y1, x2, y2):
        """<Line> of <Measurement>: counts the people crossing from (x1, y1) to (x2, y2), forward =
        towards the right-hand side seen from the first end looking at the second."""
        self._measures.append(("<Line%s/>" % _attrs(dict(id=id, x1=x1, y1=y1, x2=x2, y2=y2)), _caller()))
        return self

    def area(self, id, xmin=None, xmax=None, ymin=None, ymax=None, points=None):
        """<Area> of <Measurement>: a rectangle (xmin, xmax, ymin, ymax) or a polygon (points: a list
        of (x, y)); density, speed, specific flow and level of service in areas.csv."""
        inner = "" if points is None else _points(points)
        attrs = _attrs(dict(id=id, xmin=xmin, xmax=xmax, ymin=ymin, ymax=ymax))
        self._measures.append((("<Area%s>%s</Area>" % (attrs, inner)) if inner else "<Area%s/>" % attrs, _caller()))
        return self

    def output(self, metrics_interval=None, trajectories=None, trajectory_interval=None, flow_first=None,
               flow_last=None):
        """<Output>: metrics interval (s), trajectory files (none, txt, bin, umans, both), ..."""
        self._output = dict(metrics_interval=metrics_interval, trajectories=trajectories,
                            trajectory_interval=trajectory_interval, flow_first=flow_first, flow_last=flow_last)
        self._output_origin = _caller()
        return self

    # ---- to the loader ----------------------------------------------------------------------
    def _lines(self):
        """The scenario as the loader reads it: (text, origin) per line."""
        out = [('<?xml version="1.0" encoding="utf-8"?>', None), ("<Simulation%s>" % _attrs(self._sim), None)]
        kind, bounds = self._world[0], self._world[1]
        origin = self._world[2] if len(self._world) > 2 else None
        out.append(("<World%s>" % _attrs(dict(type=kind, **bounds)), origin))
        for xml, origin in self._obstacles:
            out.append((xml, origin))
        if self._navigation is not None:
            out.append(self._navigation)
        out.extend(self._venue)
        out.append(("</World>", None))
        out.extend(self._files["Policies"])
        out.append(("<Policies>", None))
        for pid, (attrs, steps, health, origin) in self._policies.items():
            out.append(("<Policy%s>" % _attrs(attrs), origin))
            for xml, o in steps:
                out.append((xml, o))
            if health is not None:
                out.append(("<CrowdHealth%s/>" % _attrs(health), origin))
            out.append(("</Policy>", origin))
        out.append(("</Policies>", None))
        if self._ramps:
            out.append(("<Schedule>", None))
            out.extend(self._ramps)
            out.append(("</Schedule>", None))
        if any(v is not None for v in self._output.values()):
            out.append(("<Output%s/>" % _attrs(self._output), getattr(self, "_output_origin", None)))
        if self._safety is not None:
            out.append(self._safety)
        if self._measurement is not None or self._measures:
            attrs, origin = self._measurement if self._measurement is not None else ({}, None)
            out.append(("<Measurement%s>" % _attrs(attrs), origin))
            out.extend(self._measures)
            out.append(("</Measurement>", origin))
        out.extend(self._files["Agents"])
        out.append(("<Agents>", None))
        out.extend(self._agents)
        out.append(("</Agents>", None))
        out.append(("</Simulation>", None))
        return out

    def to_xml(self):
        """The scenario as an XML file the program reads (to run it with `crowdhealth -i`)."""
        return "\n".join(text for text, _ in self._lines()) + "\n"


class Simulation(_Simulation):
    __doc__ = """Simulation(path_or_scenario, seed=None, threads=1)

    Loads a scenario file exactly as the program does (`crowdhealth -i path [--seed S] -t threads`),
    or a Scenario built in code. A bad scenario raises ScenarioError (its message holds the
    `path:line: error:` lines); the loader's warnings are issued as ScenarioWarning.
    """

    def __init__(self, path, seed=None, threads=1):
        if not isinstance(path, Scenario):
            super().__init__(os.fspath(path), seed, threads)
            return
        lines = path._lines()
        fd, tmp = tempfile.mkstemp(prefix="crowdhealth-scenario-", suffix=".xml")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write("\n".join(text for text, _ in lines) + "\n")
            try:
                super().__init__(tmp, seed, threads, path.name)
            except ScenarioError as e:
                raise ScenarioError(_explain(str(e), tmp, lines, path.name)) from None
        finally:
            os.unlink(tmp)


def _explain(message, tmp, lines, name):
    """Replaces `tmp.xml:N:` by the builder call that made line N."""
    def where(m):
        n = int(m.group(1))
        origin = lines[n - 1][1] if 1 <= n <= len(lines) else None
        return "%s: (%s, %s)" % (origin or name, name, lines[n - 1][0][:60] if 1 <= n <= len(lines) else "")
    return re.sub(re.escape(tmp) + r":(\d+):", where, message).replace(tmp, name)
