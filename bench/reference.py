"""Reference durations for `rc bench motion`.

Reads the problem set that `rc bench motion` wrote (TOML, see bench/README.md) and writes,
for every problem, the duration of the same move planned by an open reference planner:

- joint moves: ruckig (Berscheid & Kröger), the time-optimal jerk-limited trajectory for
  the same per-joint velocity, acceleration and jerk limits, rest to rest, all joints
  time-synchronised (ruckig's default: every joint arrives at the same time; the joints need
  not stay on the straight line in joint space that our planner keeps);
- linear moves: toppra (Pham & Pham), the time-optimal path parameterisation of the same
  geometric joint path (the joints our planner sampled along the line, interpolated by a
  cubic spline) under the same joint velocity and acceleration limits and the TCP's
  velocity and acceleration limits along the line. toppra has no jerk limit, so its
  duration is a lower bound for any jerk-limited timing of the path, ours included.

For every linear move it also writes a jerk-aware lower bound: the larger of toppra's
duration and the longest time-optimal jerk-limited rest-to-rest time of any single
coordinate alone, computed by ruckig (without time synchronisation, so its duration is the
slowest coordinate's own minimum time). The coordinates are the six joints from the first to
the last point of our sampled path, under that joint's velocity, acceleration and jerk
limits, and the TCP's distance along the line from 0 to `length_m`, under the TCP's
velocity, acceleration and jerk limits (on a straight line the TCP's speed, acceleration and
jerk are those of that distance). It is a lower bound for any timing of the move that keeps
those limits, ours included: every coordinate must get from its start to its end, at rest at
both, and alone it cannot be faster than its own time-optimal profile; toppra is the optimum
without the jerk limit. It is not an optimum: a joint that moves back and forth on the path
travels further than its net displacement, and the coordinates are not held to one path.

For scale, toppra also times the straight joint-space line of every joint move under the
joint velocity and acceleration limits: ruckig's duration over that one is what the jerk
limit alone costs on those moves.

Usage: python reference.py PROBLEMS.toml RESULT.toml

The result is TOML (written here by hand: the standard library reads TOML but does not
write it): the package versions, then `joint` and `linear`, one duration in seconds per
problem in input order, `nan` where the reference planner failed, `joint_toppra`, and
`linear_bound`, the jerk-aware lower bound of every linear move (`nan` where ruckig or
toppra failed).
"""

import importlib.metadata
import json
import math
import sys
import time
import tomllib

import numpy as np
import ruckig
import toppra
import toppra.algorithm
import toppra.constraint

# toppra's grid on a TCP line's joint path. Its durations fall as the grid gets finer where
# the joints turn fast over a short piece of the path (near a singular set): on the lines of
# seed 1, 500 points gave up to 1.5 % more than 8000, 4000 points within 0.03 % of 8000
# (about 0.1 s per line).
LINE_GRIDPOINTS = 4000
# toppra's grid on a straight joint-space line, where its duration does not depend on it
# (the 200 joint moves of seed 1: 500 and 4000 points within 2e-6 in all).
JOINT_LINE_GRIDPOINTS = 500


def ruckig_duration(start, target, limits, synchronised=True):
    """Duration (s) of ruckig's rest-to-rest move, nan on failure. Time-synchronised: every
    coordinate arrives at the same time; without: the duration of the slowest coordinate's
    own time-optimal profile."""
    dofs = len(start)
    inp = ruckig.InputParameter(dofs)
    if not synchronised:
        inp.synchronization = ruckig.Synchronization.No
    inp.current_position = list(start)
    inp.current_velocity = [0.0] * dofs
    inp.current_acceleration = [0.0] * dofs
    inp.target_position = list(target)
    inp.target_velocity = [0.0] * dofs
    inp.target_acceleration = [0.0] * dofs
    inp.max_velocity = list(limits["velocity"])
    inp.max_acceleration = list(limits["acceleration"])
    inp.max_jerk = list(limits["jerk"])
    trajectory = ruckig.Trajectory(dofs)
    result = ruckig.Ruckig(dofs).calculate(inp, trajectory)
    if result != ruckig.Result.Working:
        return math.nan
    return trajectory.duration


def toppra_duration(waypoints, velocity, acceleration, gridpoints):
    """Duration (s) of toppra's time-optimal rest-to-rest timing of the path through
    `waypoints` (equally spaced in the path parameter, which runs over [0, 1] like ours)
    under symmetric per-coordinate velocity and acceleration limits, on `gridpoints` equally
    spaced points; nan on failure."""
    q = np.asarray(waypoints, dtype=float)
    spline = toppra.SplineInterpolator(np.linspace(0.0, 1.0, len(q)), q)
    v = np.asarray(velocity, dtype=float)
    a = np.asarray(acceleration, dtype=float)
    constraints = [
        toppra.constraint.JointVelocityConstraint(np.column_stack([-v, v])),
        toppra.constraint.JointAccelerationConstraint(np.column_stack([-a, a])),
    ]
    instance = toppra.algorithm.TOPPRA(
        constraints,
        spline,
        gridpoints=np.linspace(0.0, 1.0, gridpoints),
        parametrizer="ParametrizeConstAccel",
    )
    trajectory = instance.compute_trajectory(0.0, 0.0)
    if trajectory is None:
        return math.nan
    return float(trajectory.duration)


def line_duration(path, length_m, joint_limits, tcp_limits):
    """toppra's duration for our sampled joint path of a TCP line.

    A seventh, virtual coordinate is the TCP's distance along the line, `length_m * s`: it
    is linear in `s`, so its velocity and acceleration limits are exactly the TCP limits
    along a straight line.
    """
    q = np.asarray(path, dtype=float)
    waypoints = np.column_stack([q, length_m * np.linspace(0.0, 1.0, len(q))])
    return toppra_duration(
        waypoints,
        np.append(joint_limits["velocity"], tcp_limits["velocity"]),
        np.append(joint_limits["acceleration"], tcp_limits["acceleration"]),
        LINE_GRIDPOINTS,
    )


def line_bound(path, length_m, toppra_s, joint_limits, tcp_limits):
    """The jerk-aware lower bound (s) of a TCP line: the larger of toppra's duration
    `toppra_s` and the slowest coordinate's time-optimal jerk-limited time alone (the joints
    from the first to the last point of `path`, the TCP's distance from 0 to `length_m`)."""
    start = list(path[0]) + [0.0]
    target = list(path[-1]) + [length_m]
    limits = {
        key: list(joint_limits[key]) + [tcp_limits[key]]
        for key in ("velocity", "acceleration", "jerk")
    }
    slowest = ruckig_duration(start, target, limits, synchronised=False)
    # Python's max() of a nan depends on the order of its arguments.
    if not (math.isfinite(slowest) and math.isfinite(toppra_s)):
        return math.nan
    return max(toppra_s, slowest)


def straight_joint_duration(start, target, joint_limits):
    """toppra's duration for the straight joint-space line of a joint move (no jerk limit):
    next to ruckig's, what the jerk limit costs on these moves."""
    waypoints = np.linspace(np.asarray(start, float), np.asarray(target, float), 5)
    return toppra_duration(
        waypoints, joint_limits["velocity"], joint_limits["acceleration"], JOINT_LINE_GRIDPOINTS
    )


def toml_floats(name, values):
    """One TOML line `name = [..]`; Python's repr of a float (nan, inf too) is valid TOML."""
    return f"{name} = [{', '.join(repr(float(x)) for x in values)}]\n"


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    with open(argv[1], "rb") as f:
        problems = tomllib.load(f)
    joint_limits = problems["joint_limits"]
    tcp_limits = problems["tcp_limits"]

    started = time.perf_counter()
    joint = [
        ruckig_duration(p["start"], p["target"], joint_limits)
        for p in problems.get("joint", [])
    ]
    ruckig_s = time.perf_counter() - started
    started = time.perf_counter()
    linear = [
        line_duration(p["path"], p["length_m"], joint_limits, tcp_limits)
        for p in problems.get("linear", [])
    ]
    toppra_s = time.perf_counter() - started
    started = time.perf_counter()
    linear_bound = [
        line_bound(p["path"], p["length_m"], d, joint_limits, tcp_limits)
        for p, d in zip(problems.get("linear", []), linear)
    ]
    ruckig_s += time.perf_counter() - started
    joint_toppra = [
        straight_joint_duration(p["start"], p["target"], joint_limits)
        for p in problems.get("joint", [])
    ]

    with open(argv[2], "w", encoding="utf-8") as f:
        # JSON strings of ASCII text are valid TOML basic strings.
        for package in ("ruckig", "toppra"):
            f.write(f"{package} = {json.dumps(importlib.metadata.version(package))}\n")
        f.write(f"ruckig_seconds = {ruckig_s!r}\n")
        f.write(f"toppra_seconds = {toppra_s!r}\n")
        f.write(toml_floats("joint", joint))
        f.write(toml_floats("linear", linear))
        f.write(toml_floats("joint_toppra", joint_toppra))
        f.write(toml_floats("linear_bound", linear_bound))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
