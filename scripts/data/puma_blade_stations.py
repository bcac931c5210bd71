#!/usr/bin/python3
"""Writes the research Puma's blade section tables (docs/reference/puma.md, from Bousman et
al., NASA TM 110421, as in MBDyn's Puma example) as `stations { ... }` blocks of a scenario's
beam (proto/scenario/structure.proto, BeamStation), so that the tables are typed once, here.

Every property is piecewise linear in r with its own breakpoints; the stations are the union of
all breakpoints, with two stations at an r where any property jumps (left and right values).
Units: r [m], twist [rad] (the tables' degrees converted), c.g. offset [m] (the tables' chord
fraction times c = 0.537 m, positive towards the leading edge, i.e. along the beam's `chord`).
With --clockwise the twist is negated: the Puma's rotor turns clockwise seen from above, so a
beam whose chord axis d2 points to the leading edge has its flapwise axis d3 = d1 × d2
pointing down, and a nose-up twist is a negative rotation about d1.
Usage: puma_blade_stations.py [--clockwise] [INDENT]  (prints to standard output)
"""
import math
import sys

CHORD = 0.537

# (a, b, value at a, value at b) per interval, from puma.md.
TWIST_DEG = [
    (0.280, 1.757, 0, 0),
    (1.757, 2.007, 0, -0.100),
    (2.007, 2.257, -0.100, -0.300),
    (2.257, 2.507, -0.300, -0.617),
    (2.507, 2.757, -0.617, -0.983),
    (2.757, 3.007, -0.983, -1.283),
    (3.007, 3.257, -1.283, -1.600),
    (3.257, 3.507, -1.600, -1.867),
    (3.507, 6.257, -1.867, -4.800),
    (6.257, 7.490, -4.800, -6.117),
]
MASS = [
    (0.280, 0.610, 58.400, 58.400),
    (0.610, 0.730, 50.000, 50.000),
    (0.730, 0.754, 16.175, 16.175),
    (0.754, 0.760, 53.333, 53.333),
    (0.760, 0.800, 24.949, 24.949),
    (0.800, 0.840, 33.100, 33.100),
    (0.840, 1.040, 22.400, 22.400),
    (1.040, 1.110, 17.110, 17.110),
    (1.110, 1.260, 11.225, 11.225),
    (1.260, 1.770, 7.150, 7.150),
    (1.770, 1.887, 7.150, 8.929),
    (1.887, 7.070, 8.929, 8.929),
    (7.070, 7.390, 12.754, 12.754),
    (7.390, 7.402, 34.600, 34.600),
    (7.402, 7.490, 6.930, 6.930),
]
CG_FRACTION = [
    (0.280, 1.887, 0, 0),
    (1.887, 7.070, -0.010, -0.010),
    (7.070, 7.390, 0.030, 0.030),
    (7.390, 7.402, 0.147, 0.147),
    (7.402, 7.490, 0, 0),
]
EA = [
    (0.280, 0.760, 5.69e8, 5.69e8),
    (0.760, 0.820, 5.63e8, 5.63e8),
    (0.820, 0.873, 3.77e8, 3.77e8),
    (0.873, 0.965, 5.69e8, 5.69e8),
    (0.965, 1.040, 5.50e8, 5.50e8),
    (1.040, 1.111, 4.74e8, 4.74e8),
    (1.111, 1.260, 3.74e8, 3.74e8),
    (1.260, 1.697, 1.70e8, 1.69e8),
    (1.697, 1.757, 1.69e8, 1.65e8),
    (1.757, 1.880, 1.65e8, 1.71e8),
    (1.880, 2.128, 1.71e8, 1.70e8),
    (2.128, 2.278, 1.70e8, 1.51e8),
    (2.278, 5.250, 1.51e8, 1.45e8),
    (5.250, 5.800, 1.45e8, 1.44e8),
    (5.800, 6.110, 1.44e8, 1.43e8),
    (6.110, 7.350, 1.43e8, 1.43e8),
    (7.350, 7.382, 1.61e8, 1.61e8),
    (7.382, 7.490, 1.16e8, 1.16e8),
]
EI_FLAP = [
    (0.280, 0.600, 1.78e6, 1.78e6),
    (0.600, 0.610, 1.78e6, 1.37e6),
    (0.610, 0.800, 1.37e6, 1.37e6),
    (0.800, 0.810, 1.37e6, 4.12e5),
    (0.810, 1.240, 4.12e5, 4.10e5),
    (1.240, 1.250, 4.10e5, 8.1e4),
    (1.250, 7.300, 8.1e4, 8.1e4),
    (7.300, 7.310, 8.1e4, 8.2e4),
    (7.310, 7.490, 8.2e4, 8.2e4),
]
EI_LAG = [
    (0.280, 0.600, 1.78e6, 1.78e6),
    (0.600, 0.610, 1.78e6, 1.37e6),
    (0.610, 0.800, 1.37e6, 1.37e6),
    (0.800, 0.810, 1.37e6, 1.78e6),
    (0.810, 1.240, 1.78e6, 1.78e6),
    (1.240, 1.250, 1.78e6, 1.53e6),
    (1.250, 7.300, 1.53e6, 1.44e6),
    (7.300, 7.310, 1.44e6, 7.15e5),
    (7.310, 7.490, 7.15e5, 7.15e5),
]
GJ = [
    (0.280, 0.725, 8.4e5, 8.4e5),
    (0.725, 0.828, 2.26e6, 2.26e6),
    (0.828, 1.017, 5.05e5, 5.05e5),
    (1.017, 7.241, 8.5e4, 8.5e4),
    (7.241, 7.490, 8.7e4, 8.7e4),
]
TORSION_INERTIA = [
    (0.280, 0.604, 0, 0),
    (0.604, 0.610, 0.192, 0.192),
    (0.610, 0.730, 0.164, 0.178),
    (0.730, 0.754, 0.116, 0.130),
    (0.754, 0.760, 0.427, 0.438),
    (0.760, 0.800, 0.205, 0.240),
    (0.800, 0.836, 0.318, 0.359),
    (0.836, 0.837, 0.359, 0.120),
    (0.837, 0.840, 0.120, 0.121),
    (0.840, 1.017, 0.082, 0.121),
    (1.017, 1.040, 0.121, 0.098),
    (1.040, 1.085, 0.075, 0.040),
    (1.085, 1.110, 0.040, 0.040),
    (1.110, 1.260, 0.026, 0.026),
    (1.260, 1.770, 0.017, 0.037),
    (1.770, 1.887, 0.087, 0.109),
    (1.887, 7.070, 0.109, 0.109),
    (7.070, 7.390, 0.156, 0.156),
    (7.390, 7.402, 0.337, 0.067),
    (7.402, 7.434, 0.067, 0.067),
    (7.434, 7.490, 0.118, 0.118),
]

PROPERTIES = [
    ("ea", EA, 1.0),
    ("gj", GJ, 1.0),
    ("ei_flap", EI_FLAP, 1.0),
    ("ei_lag", EI_LAG, 1.0),
    ("mass", MASS, 1.0),
    ("cg_chord", CG_FRACTION, CHORD),
    ("inertia_torsion", TORSION_INERTIA, 1.0),
    ("twist", TWIST_DEG, math.pi / 180.0),
]


def value(table, r, side):
    """The property at r, from the interval on the left (side < 0) or on the right (side > 0)."""
    for a, b, va, vb in table:
        if (side < 0 and a < r <= b) or (side > 0 and a <= r < b):
            return va + (vb - va) * (r - a) / (b - a)
    a, b, va, vb = table[0] if r <= table[0][0] else table[-1]
    return va if r <= a else vb


def stations():
    rs = sorted({x for _, table, _ in PROPERTIES for a, b, _, _ in table for x in (a, b)})
    out = []
    for r in rs:
        left = {name: value(t, r, -1) * scale for name, t, scale in PROPERTIES}
        right = {name: value(t, r, +1) * scale for name, t, scale in PROPERTIES}
        if r == rs[0]:
            out.append((r, right))
        elif r == rs[-1]:
            out.append((r, left))
        elif any(abs(left[k] - right[k]) > 1e-12 * max(1.0, abs(left[k])) for k in left):
            out.append((r, left))
            out.append((r, right))
        else:
            out.append((r, left))
    return out


def main():
    args = [a for a in sys.argv[1:] if a != "--clockwise"]
    sign = -1.0 if "--clockwise" in sys.argv[1:] else 1.0
    indent = " " * (int(args[0]) if args else 4)
    for r, p in stations():
        p = dict(p, twist=sign * p["twist"] + 0.0)
        fields = " ".join(f"{k}: {p[k]:.10g}" for k, _, _ in PROPERTIES)
        print(f"{indent}stations {{ s: {r:.4f} {fields} }}")


if __name__ == "__main__":
    main()
