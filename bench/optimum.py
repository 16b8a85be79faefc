"""Jerk-limited time-optimal durations of the linear moves of `rc bench motion`.

Reads the problem set that `rc bench motion` wrote (TOML, see bench/README.md) and writes,
for the first COUNT linear moves, the shortest duration of the move along the same joint
path under the same limits as ours as planned: joint velocity, acceleration and jerk, and
the TCP's velocity, acceleration and jerk along the line, the accelerations held back by the
override reserve (`override_reserve`) as our planner holds them back. No reference package
computes that, so it is solved here as a nonlinear program by direct collocation (CasADi
with IPOPT):

- the path: our joints sampled at equal shares of the line (the problem file's `path`),
  interpolated by a quintic spline, whose first three derivatives by the share `s` give the
  joints' `q'`, `q''`, `q'''` (on a straight line the TCP's distance is `length_m * s`);
- the timing: `s(t)` from rest at 0 to rest at 1 in `N` steps of equal length `T/N`, with a
  constant path jerk in every step (so `s`, `ṡ` and `s̈` follow exactly from step to step),
  minimising `T`;
- the limits, at every step boundary: `|q'·ṡ| ≤ v`, `|q''·ṡ² + q'·s̈| ≤ a`, and the
  jerk `|q'''·ṡ³ + 3·q''·ṡ·s̈ + q'·s⃛| ≤ j` with the jerk of the steps on either side;
  the TCP's `length·ṡ`, `length·|s̈|` and `length·|s⃛|` within its limits.

The limits hold at the step boundaries only, so the result can be a little shorter than a
timing that keeps them everywhere: it is the reference, not a bound that ours must keep. A
line whose program does not converge gets `nan`.

Usage: python optimum.py PROBLEMS.toml RESULT.toml COUNT

The result is TOML: the CasADi version, the seconds spent, `linear_optimum`, one duration
in seconds per linear move of the problem file (`nan` after the first COUNT), and
`linear_optimum_largest_term`, per line the largest share of its limit that one term of a
joint's acceleration or jerk takes in the optimum (see `largest_term`).
"""

import importlib.metadata
import json
import math
import sys
import time
import tomllib

try:
    import casadi
except ImportError:
    sys.exit("optimum.py: CasADi is not installed (bash bench/setup.sh installs it)")
import numpy as np
from scipy.interpolate import make_interp_spline

# Time steps of the collocation.
STEPS = 150
# Points at which the path's derivatives are tabulated for the program.
TABLE_POINTS = 2049
# Largest IPOPT iterations per line.
MAX_ITERATIONS = 3000
# Durations of the initial guesses, over ours, tried in turn until IPOPT converges (from a
# guess at our duration it fails on about one line in twenty, from a slower one it succeeds).
GUESS_FACTORS = (1.0, 1.3, 1.6)


def derivative_tables(path):
    """The grid of `s` and the first three derivatives of the joints by `s` on it."""
    q = np.asarray(path, dtype=float)
    spline = make_interp_spline(np.linspace(0.0, 1.0, len(q)), q, k=5)
    grid = np.linspace(0.0, 1.0, TABLE_POINTS)
    return grid, [spline.derivative(n)(grid) for n in (1, 2, 3)]


def interpolant(name, grid, values):
    """A smooth CasADi function of `s` through the tabulated `values` (one column a joint;
    CasADi takes the outputs of a grid point next to each other)."""
    return casadi.interpolant(name, "bspline", [grid], values.ravel(order="C").tolist())


def initial_guess(duration):
    """`(s, ṡ, s̈)` at the step boundaries and the jerk of every step of the rest-to-rest
    polynomial `s = 35τ⁴ − 84τ⁵ + 70τ⁶ − 20τ⁷` over `duration`."""
    tau = np.linspace(0.0, 1.0, STEPS + 1)
    s = 35 * tau**4 - 84 * tau**5 + 70 * tau**6 - 20 * tau**7
    v = (140 * tau**3 - 420 * tau**4 + 420 * tau**5 - 140 * tau**6) / duration
    a = (420 * tau**2 - 1680 * tau**3 + 2100 * tau**4 - 840 * tau**5) / duration**2
    middle = 0.5 * (tau[1:] + tau[:-1])
    jerk = (840 * middle - 5040 * middle**2 + 8400 * middle**3 - 4200 * middle**4) / duration**3
    return s, v, a, jerk


def optimum(path, length_m, joint_limits, tcp_limits, guess_s):
    """The shortest duration (s) of the line along `path`, IPOPT started from profiles of
    `guess_s` times each of `GUESS_FACTORS`, and its `largest_term`; both nan if it
    converges from none."""
    grid, tables = derivative_tables(path)
    d1, d2, d3 = (interpolant(f"d{n}", grid, t) for n, t in zip((1, 2, 3), tables))
    v_max = np.asarray(joint_limits["velocity"], float)
    a_max = np.asarray(joint_limits["acceleration"], float)
    j_max = np.asarray(joint_limits["jerk"], float)

    opti = casadi.Opti()
    duration = opti.variable()
    s = opti.variable(STEPS + 1)
    v = opti.variable(STEPS + 1)
    a = opti.variable(STEPS + 1)
    jerk = opti.variable(STEPS)
    h = duration / STEPS
    opti.minimize(duration)
    opti.subject_to(duration > 0)
    for n in range(STEPS):
        u = jerk[n]
        opti.subject_to(s[n + 1] == s[n] + h * v[n] + h**2 / 2 * a[n] + h**3 / 6 * u)
        opti.subject_to(v[n + 1] == v[n] + h * a[n] + h**2 / 2 * u)
        opti.subject_to(a[n + 1] == a[n] + h * u)
    for end in (0, STEPS):
        opti.subject_to(v[end] == 0)
        opti.subject_to(a[end] == 0)
    opti.subject_to(s[0] == 0)
    opti.subject_to(s[STEPS] == 1)
    opti.subject_to(opti.bounded(0, s, 1))
    opti.subject_to(v >= 0)
    opti.subject_to(length_m * v <= tcp_limits["velocity"])
    for limit, value in ((tcp_limits["acceleration"], a), (tcp_limits["jerk"], jerk)):
        opti.subject_to(opti.bounded(-limit, length_m * value, limit))
    for n in range(STEPS + 1):
        p1, p2, p3 = d1(s[n]), d2(s[n]), d3(s[n])
        opti.subject_to(opti.bounded(-v_max, p1 * v[n], v_max))
        opti.subject_to(opti.bounded(-a_max, p2 * v[n] ** 2 + p1 * a[n], a_max))
        moving = p3 * v[n] ** 3 + 3 * p2 * v[n] * a[n]
        for step in (n - 1, n):
            if 0 <= step < STEPS:
                opti.subject_to(opti.bounded(-j_max, moving + p1 * jerk[step], j_max))

    opti.solver(
        "ipopt",
        {"print_time": False},
        {"print_level": 0, "max_iter": MAX_ITERATIONS, "tol": 1e-9, "sb": "yes"},
    )
    for factor in GUESS_FACTORS:
        gs, gv, ga, gj = initial_guess(factor * guess_s)
        opti.set_initial(duration, factor * guess_s)
        opti.set_initial(s, gs)
        opti.set_initial(v, gv)
        opti.set_initial(a, ga)
        opti.set_initial(jerk, gj)
        try:
            solution = opti.solve()
        except RuntimeError:
            continue
        profile = [np.asarray(solution.value(x), float).ravel() for x in (s, v, a, jerk)]
        term = largest_term(profile, (d1, d2, d3), a_max, j_max)
        return float(solution.value(duration)), term
    return math.nan, math.nan


def largest_term(profile, derivatives, a_max, j_max):
    """The largest share of its limit that one term of a joint's acceleration (`q''·ṡ²`,
    `q'·s̈`) or jerk (`q'''·ṡ³`, `3·q''·ṡ·s̈`, `q'·s⃛` with the jerk of either step) takes at a
    step boundary of the solved `profile` `(s, ṡ, s̈, s⃛)`, with the path's `derivatives`
    (the interpolants the program used): above 1 where the optimum lets terms beyond their
    limit cancel each other."""
    s, v, a, jerk = profile
    d1, d2, d3 = (np.asarray(d.map(len(s))(s)).T for d in derivatives)
    v, a = v[:, None], a[:, None]
    before = np.concatenate(([jerk[0]], jerk))[:, None]
    after = np.concatenate((jerk, [jerk[-1]]))[:, None]
    shares = [
        np.abs(d2 * v**2) / a_max,
        np.abs(d1 * a) / a_max,
        np.abs(d3 * v**3) / j_max,
        np.abs(3 * d2 * v * a) / j_max,
        np.abs(d1 * before) / j_max,
        np.abs(d1 * after) / j_max,
    ]
    return float(max(x.max() for x in shares))


def limits_as_planned(problems):
    """The joint and TCP limits of the problem file with the accelerations held back by the
    override reserve, as our planner plans a line."""
    kept = 1.0 - problems["override_reserve"]
    joint_limits = dict(problems["joint_limits"])
    joint_limits["acceleration"] = [kept * a for a in joint_limits["acceleration"]]
    tcp_limits = dict(problems["tcp_limits"])
    tcp_limits["acceleration"] *= kept
    return joint_limits, tcp_limits


def main(argv):
    try:
        _, problems_file, result_file, count = argv
        count = int(count)
    except ValueError:
        print(__doc__, file=sys.stderr)
        return 2
    with open(problems_file, "rb") as f:
        problems = tomllib.load(f)
    joint_limits, tcp_limits = limits_as_planned(problems)
    started = time.perf_counter()
    solved = [
        optimum(p["path"], p["length_m"], joint_limits, tcp_limits, p["ours_s"])
        if k < count
        else (math.nan, math.nan)
        for k, p in enumerate(problems.get("linear", []))
    ]
    durations = [d for d, _ in solved]
    terms = [t for _, t in solved]
    seconds = time.perf_counter() - started
    with open(result_file, "w", encoding="utf-8") as f:
        f.write(f"casadi = {json.dumps(importlib.metadata.version('casadi'))}\n")
        f.write(f"optimum_seconds = {seconds!r}\n")
        f.write(f"linear_optimum = [{', '.join(repr(float(x)) for x in durations)}]\n")
        terms_text = ", ".join(repr(float(x)) for x in terms)
        f.write(f"linear_optimum_largest_term = [{terms_text}]\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
