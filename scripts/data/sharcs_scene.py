#!/usr/bin/env python3
"""Writes the SHARCS-like articulated hub of the CGα paper (Section 6; docs/reference/sharcs.md)
as a scenario file: the hub chain of Table 7 with the hinge values of Table 8, the pitch-link loop
closed at the pitch horn by the initial-condition solver, one elastic blade.

Usage: sharcs_scene.py hex27 > scenarios/sharcs/hub.pbtxt       (27-node hexahedra)
       sharcs_scene.py beam  > scenarios/sharcs/hub_beam.pbtxt  (the beams issue's beam)

Every number the paper does not give is a choice stated in the file's comments; the masses and
inertias of the links are computed here from Table 7 (solid steel cylinders).
"""
import math
import sys

KIND = sys.argv[1] if len(sys.argv) > 1 else "hex27"
if KIND not in ("hex27", "beam"):
    sys.exit(f"usage: sharcs_scene.py hex27|beam (got {KIND!r})")

STEEL = 7960.0
DEG = math.pi / 180.0
# Table 7 [m]: length, radius (density 7960 where the paper gives one).
H, R_H = 0.05160, 0.01750
LP, R_LP = 0.07445, 0.01750
D_GRIP = 0.1091
PSX, PSY = 0.05160, 0.03985
PL, R_PL = 0.1120, 0.00635
PA, R_PA = 0.03810, 0.00635
PH, R_PH = 0.03985, 0.00635
PO = 0.03635
# Table 8 and the run.
BETA0, THETA0 = 1.5 * DEG, 1.93 * DEG
OMEGA, TAU, T_FULL = 168.2, 0.1, 0.2
# The blade (sharcs.md's choices).
RADIUS, CHORD, THICK = 0.9, 0.07, 0.0084
RHO_B, E_B, NU_B = 1770.0, 30e9, 0.3
TWIST = -8.0 * DEG  # linear, root to tip, zero at 0.75 R
E = H  # flap and lag hinges (F has zero length)
ROOT_R = H + LP + D_GRIP  # blade root on the pitch axis
SPAN = RADIUS - ROOT_R


def cylinder(length, radius, start, direction):
    """Mass, centre, inertia (3x3, global axes) of a solid steel cylinder from `start` along a unit axis."""
    m = STEEL * math.pi * radius ** 2 * length
    c = [start[i] + 0.5 * length * direction[i] for i in range(3)]
    ia = 0.5 * m * radius ** 2
    it = m * (3 * radius ** 2 + length ** 2) / 12.0
    inertia = [[it * (1.0 if i == j else 0.0) + (ia - it) * direction[i] * direction[j] for j in range(3)] for i in range(3)]
    return m, c, inertia


def combine(parts):
    """Mass, centre and inertia about the centre of rigidly joined parts (each mass, centre, inertia)."""
    m = sum(p[0] for p in parts)
    c = [sum(p[0] * p[1][i] for p in parts) / m for i in range(3)]
    inertia = [[0.0] * 3 for _ in range(3)]
    for pm, pc, pi_ in parts:
        d = [pc[i] - c[i] for i in range(3)]
        dd = sum(x * x for x in d)
        for i in range(3):
            for j in range(3):
                inertia[i][j] += pi_[i][j] + pm * ((dd if i == j else 0.0) - d[i] * d[j])
    return m, c, inertia


def rot_y(a):  # rotation about +y by a
    ca, sa = math.cos(a), math.sin(a)
    return [[ca, 0, sa], [0, 1, 0], [-sa, 0, ca]]


def rot_x(a):
    ca, sa = math.cos(a), math.sin(a)
    return [[1, 0, 0], [0, ca, -sa], [0, sa, ca]]


def mul(A, B):
    return [[sum(A[i][k] * B[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def apply(A, v):
    return [sum(A[i][k] * v[k] for k in range(3)) for i in range(3)]


def rotvec(A):
    """Rotation vector of a rotation matrix (angles well below π here)."""
    angle = math.acos(max(-1.0, min(1.0, 0.5 * (A[0][0] + A[1][1] + A[2][2] - 1.0))))
    if angle < 1e-15:
        return [0.0, 0.0, 0.0]
    k = angle / (2.0 * math.sin(angle))
    return [k * (A[2][1] - A[1][2]), k * (A[0][2] - A[2][0]), k * (A[1][0] - A[0][1])]


def v(x):
    return "[" + ", ".join(f"{c:.12g}" for c in x) + "]"


def inertia6(I):
    return v([I[0][0], I[1][1], I[2][2], I[0][1], I[0][2], I[1][2]])


R_FLAP = rot_y(-BETA0)  # flap up: about −y, the blade's x towards +z
R_BLADE = mul(R_FLAP, rot_x(THETA0))  # then pitch nose up about the blade's x
HINGE = [E, 0.0, 0.0]


def flapped(p, R=R_FLAP):
    """A point given in the hub frame of the unflapped, unpitched blade, posed by R about the hinge."""
    return [HINGE[i] + apply(R, [p[k] - HINGE[k] for k in range(3)])[i] for i in range(3)]


X = [1.0, 0.0, 0.0]
# Links in the blade's own (unrotated) frame.
hub = cylinder(H, R_H, [0.0, 0.0, 0.0], X)
lag = cylinder(LP, R_LP, [E, 0.0, 0.0], X)
HORN_ROOT = [ROOT_R - D_GRIP - PO, 0.0, 0.0]  # on the pitch axis, PO inboard of the pitch bearing
HORN_TIP = [HORN_ROOT[0] - PA, PSY, 0.0]     # PH across, PA back inboard: above the swashplate point
horn_ph = cylinder(PH, R_PH, HORN_ROOT, [0.0, 1.0, 0.0])
horn_pa = cylinder(PA, R_PA, [HORN_ROOT[0], PSY, 0.0], [-1.0, 0.0, 0.0])
pitch = combine([horn_ph, horn_pa])
SWASH = [PSX, PSY, -PL]
link = cylinder(PL, R_PL, SWASH, [0.0, 0.0, 1.0])
APL_MASS = 0.05
# Posed: the lag link flapped, the pitch body flapped and pitched (its inertia in its own axes,
# which are the blade's: the scenario's inertia is in body axes).
lag_c = flapped(lag[1])
pitch_c = flapped(pitch[1], R_BLADE)
bearing = flapped([ROOT_R - D_GRIP, 0.0, 0.0])
root = flapped([ROOT_R, 0.0, 0.0])
axis_b = apply(R_FLAP, X)
lag_axis = apply(R_FLAP, [0.0, 0.0, -1.0])
horn_offset = [HORN_TIP[i] - pitch[1][i] for i in range(3)]  # the cut joint in the pitch body's axes
tw_root = -TWIST * (0.75 * RADIUS - ROOT_R) / SPAN
tw_tip = tw_root + TWIST
tip_closed = flapped(HORN_TIP, R_BLADE)

header = f"""# SHARCS-like articulated hub of the CGα paper (Section 6), {"27-node hexahedral" if KIND == "hex27" else "beam (the beams issue's)"} blade.
# Generated by scripts/data/sharcs_scene.py {KIND}. Data: docs/reference/sharcs.md (the paper's
# Tables 7 and 8 and the choices for what it leaves out), aero.md.
# Hub frame: shaft +z, the rotor turning counter-clockwise seen from above (+z), blade 1 along +x
# at azimuth 0, its leading edge towards +y. From the paper:
# - links of Table 7 as solid steel cylinders (7960 kg/m³): hub arm H 0.0516 m (r 17.5 mm,
#   {hub[0]:.4f} kg), flap link F of zero length (flap and lag hinges coincide at r = 0.0516 m, flap
#   first), lag-and-pitch link L+P 0.07445 m ({lag[0]:.4f} kg) to the pitch bearing, blade grip d
#   0.1091 m (massless: density 0): the blade root at r = {ROOT_R:.5f} m;
# - pitch link PL 0.112 m (r 6.35 mm, {link[0]:.4f} kg) from the swashplate point (Psx, Psy) =
#   (0.0516, 0.03985) m, the APL a 0.05 kg point mass, locked; swashplate locked; hub driven by
#   Eq. (37) to {OMEGA} rad/s (sharcs.md: the paper's 1555 rpm is 162.8 rad/s; 168.2 is its first figure);
# - Table 8: azimuth 0, flap 1.5°, pitch 1.93°, cyclic 0, PL = PL2 = 0.112 m; ρ∞ = 0.95;
# - the loop closed at the pitch horn by the initial-condition solver: the cut is the spherical
#   joint `horn` (three constraint forces), given by its offsets in the two bodies' frames so
#   that the given poses need not close it; no hand-computed closure.
# Choices where the paper leaves gaps (sharcs.md):
# - link meanings: PO (0.03635 m, massless) is the pitch housing's inboard offset from the pitch
#   bearing to the horn's root on the pitch axis (r = {HORN_ROOT[0]:.4f} m); the horn is PH (0.03985 m
#   across the chord towards the leading edge) and PA (0.0381 m back inboard), steel, on the pitch
#   body ({pitch[0]:.4f} kg together): its tip sits at (Psx, Psy) = (0.0516, 0.03985) m, on the flap
#   hinge's axis (no pitch–flap coupling, δ3 = 0) and straight above the swashplate point — the
#   reading in which Table 7 adds up (Psx = H, Psy = PH, PO + PA = L+P);
# - the pitch link: universal joint at the swashplate (the paper locks its "bottom spherical
#   joint"; locked outright it would leave flap, lag and pitch no freedom, against Fig. 9: the
#   universal keeps the link's spin out and lets it swing), its upper part the APL, on a prismatic
#   joint along the link, locked at the length that closes the loop (`lock_at_closure`): with the
#   swashplate point 0.112 m below the horn at zero pitch, 1.93° of pitch lifts the horn tip
#   ~1.3 mm and the closure extends the APL by that (summary: initial_position_change);
# - the flap link F (zero length, density given, so no mass): 1 g and 1e-8 kg m², a regular mass
#   matrix; the hub body is the arm H only (the hub is driven: its inertia does not enter);
# - start-up: τ = {TAU} s (sharcs.md: 0.05–0.1 s); flap and lag held (locked) during it and
#   released at t = τ, at full speed; the pitch is never locked: the pitch link holds it (a lock
#   on it too would make the loop's cut equations redundant while the hinges are locked); then
#   {T_FULL} s at full speed (≈ {OMEGA * T_FULL / (2 * math.pi):.1f} revolutions);
# - blade: radius 0.9 m, span {SPAN:.5f} m from the grip, chord 0.07 m, 8.4 mm thick (12 %),
#   ρ = 1770 kg/m³ (the paper's Table 1), E = 30 GPa, ν = 0.3 (composite-like), no structural
#   damping (the paper names none); twist linear −8° root to tip, zero at 0.75 R (where a
#   collective is read), so the sections sit at 1.93° + {tw_root / DEG:.3f}° at the root and
#   1.93° {tw_tip / DEG:+.3f}° at the tip;
# - air ("trim hover"): strip theory on the blade from its root, NACA 0012, uniform momentum
#   inflow of a four-blade rotor (`blades: 4`: one blade modelled, as the paper's figures need);
#   still sea-level air.
# Numerics: h = 1e-4 s, ρ∞ = 0.95 (the paper's); CGα's default projected form with the Newton
# matrix rebuilt every iteration. Measured alternatives: the paper's index-3 form with the matrix
# reused over 20 steps runs 3–4× faster with the same flap angle (0.5439° against 0.5432° at
# 0.15 s), but its multipliers — the root and cut forces of Figs. 10–11 — did not converge under
# step refinement at ρ∞ = 0.95 and it failed from h = 6.25e-4 s (Ωh = 0.1); reuse with the
# projected form moved the answer (0.600°: the projection follows the stale matrix's directions).
"""

if KIND == "hex27":
    blade = f"""  elastic_bodies {{
    name: "blade"
    material {{ density: {RHO_B:g} young: {E_B:g} poisson: {NU_B:g} }}
    beam {{ length: {SPAN:.12g} chord: {CHORD:g} thickness: {THICK:g} elements_along: 10
           root: {v(root)} axis: {v(axis_b)} twist: [{THETA0 + tw_root:.12g}, {THETA0 + tw_tip:.12g}] }}
    clamps {{ body: "pitch" face: "root" }}
  }}"""
    surface_carrier = 'elastic_body: "blade"'
    root_probes = """  probes { name: "root_force_x" quantity: REACTION_FORCE entity: "blade" component: X frame: "hub" }
  probes { name: "root_force_y" quantity: REACTION_FORCE entity: "blade" component: Y frame: "hub" }
  probes { name: "root_force_z" quantity: REACTION_FORCE entity: "blade" component: Z frame: "hub" }
  probes { name: "tip_x" quantity: DISPLACEMENT entity: "blade" point: "tip_centre" component: X frame: "hub" }
  probes { name: "tip_y" quantity: DISPLACEMENT entity: "blade" point: "tip_centre" component: Y frame: "hub" }
  probes { name: "tip_z" quantity: DISPLACEMENT entity: "blade" point: "tip_centre" component: Z frame: "hub" }"""
else:
    # The same blade as a geometrically exact beam (the beams issue): a homogeneous rectangle.
    area = CHORD * THICK
    shear_modulus = E_B / (2 * (1 + NU_B))
    torsion_constant = CHORD * THICK ** 3 / 3 * (1 - 0.63 * THICK / CHORD + 0.052 * (THICK / CHORD) ** 5)
    section = (f"ea: {E_B * area:.8g} ga_chord: {5 / 6 * shear_modulus * area:.8g} ga_flap: {5 / 6 * shear_modulus * area:.8g} "
               f"gj: {shear_modulus * torsion_constant:.8g} ei_flap: {E_B * CHORD * THICK ** 3 / 12:.8g} "
               f"ei_lag: {E_B * THICK * CHORD ** 3 / 12:.8g} mass: {RHO_B * area:.8g} "
               f"inertia_torsion: {RHO_B * (CHORD ** 3 * THICK + CHORD * THICK ** 3) / 12:.8g} "
               f"inertia_flap: {RHO_B * CHORD * THICK ** 3 / 12:.8g}")
    blade = f"""  # The blade as a beam: 10 quadratic elements, the hex27 blade's rectangle (EA, EI = E I of the
  # rectangle, GA = 5/6 G A, GJ = G β c t³ with Roark's β for c/t = 8.3), clamped to the pitch body.
  beams {{
    name: "blade"
    root: {v(root)} axis: {v(axis_b)} chord: [0, 1, 0]
    elements: 10 nodes_per_element: 3 root_body: "pitch"
    stations {{ s: 0 {section} twist: {THETA0 + tw_root:.12g} }}
    stations {{ s: {SPAN:.12g} {section} twist: {THETA0 + tw_tip:.12g} }}
  }}"""
    surface_carrier = 'beam: "blade"'
    root_probes = """  probes { name: "root_force_x" quantity: REACTION_FORCE entity: "blade.root_clamp" component: X frame: "hub" }
  probes { name: "root_force_y" quantity: REACTION_FORCE entity: "blade.root_clamp" component: Y frame: "hub" }
  probes { name: "root_force_z" quantity: REACTION_FORCE entity: "blade.root_clamp" component: Z frame: "hub" }
  probes { name: "tip_x" quantity: DISPLACEMENT entity: "blade.n20" component: X frame: "hub" }
  probes { name: "tip_y" quantity: DISPLACEMENT entity: "blade.n20" component: Y frame: "hub" }
  probes { name: "tip_z" quantity: DISPLACEMENT entity: "blade.n20" component: Z frame: "hub" }"""

# `scripts/cosim study compare` draws the paper's Figs. 9–11 for both blade models; `study
# convergence` is Fig. 12 (with --set numerics.end_time=0.27: the paper's 0.02 s window after the
# release's transients have settled for 0.15 s, every run starting from one settling run's state).
STUDY = f"""study {{
  probes: ["flap", "lag", "pitch_link_z_mm", "root_force_x", "root_force_y", "root_force_z",
           "cut_force_x", "cut_force_y", "cut_force_z", "tip_x", "tip_y", "tip_z"]
  compare {{ name: "hex27 blade" scenario: "hub.pbtxt" }}
  compare {{ name: "beam blade" scenario: "hub_beam.pbtxt" }}
  restart_time: {TAU + 0.15:g}
  error_from: {TAU + 0.15:g}
  coarsest_step: 0.01
  halvings: 8
}}
"""
if KIND == "hex27":  # the mesh's sections: the reference chord twisted by the stations' twist
    SURFACE = (f"{surface_carrier} root: {v(root)} axis: {v(axis_b)} chord: [0, 1, 0] upper: [0, 0, 1]\n"
               f"               stations {{ s: 0 chord: {CHORD} twist: {THETA0 + tw_root:.12g} airfoil: \"naca0012\" }}\n"
               f"               stations {{ s: {SPAN:.12g} chord: {CHORD} twist: {THETA0 + tw_tip:.12g} airfoil: \"naca0012\" }}")
else:  # the beam's section frames carry pitch and twist already
    SURFACE = (f"{surface_carrier} upper: [0, 0, 1]\n"
               f"               stations {{ s: 0 chord: {CHORD} airfoil: \"naca0012\" }} stations {{ s: {SPAN:.12g} chord: {CHORD} airfoil: \"naca0012\" }}")
body = f"""name: "sharcs_hub{'' if KIND == 'hex27' else '_beam'}"
description: "SHARCS-like articulated hub (CGα paper, Section 6): pitch-link loop, {'hex27' if KIND == 'hex27' else 'beam'} blade, start-up and release"
model {{
  gravity: [0, 0, -9.81]
  bodies {{ name: "hub" mass: {hub[0]:.6g} inertia: {inertia6(hub[2])} position: {v(hub[1])} }}
  bodies {{ name: "flap_link" mass: 0.001 inertia: [1e-8, 1e-8, 1e-8] position: {v(HINGE)} rotation: {v(rotvec(R_FLAP))} }}
  bodies {{ name: "lag_link" mass: {lag[0]:.6g} inertia: {inertia6(lag[2])} position: {v(lag_c)} rotation: {v(rotvec(R_FLAP))} }}
  bodies {{ name: "pitch" mass: {pitch[0]:.6g} inertia: {inertia6(pitch[2])} position: {v(pitch_c)} rotation: {v(rotvec(R_BLADE))} }}
  bodies {{ name: "pitch_link" mass: {link[0]:.6g} inertia: {inertia6(link[2])} position: {v(link[1])} }}
  bodies {{ name: "apl" mass: {APL_MASS} inertia: [1e-7, 1e-7, 1e-7] position: {v([PSX, PSY, 0.0])} }}
  joints {{ name: "shaft" type: REVOLUTE body1: "ground" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]
           drive {{ quantity: ANGULAR_SPEED function {{ cosine_ramp {{ final_value: {OMEGA} ramp_time: {TAU} }} }} }} }}
  joints {{ name: "flap" type: REVOLUTE body1: "hub" body2: "flap_link" point: {v(HINGE)} axis: [0, -1, 0]
           locked: true release_time: {TAU} initial_coordinate: {BETA0:.12g} }}
  joints {{ name: "lag" type: REVOLUTE body1: "flap_link" body2: "lag_link" point: {v(HINGE)} axis: {v(lag_axis)}
           locked: true release_time: {TAU} }}
  joints {{ name: "pitch_bearing" type: REVOLUTE body1: "lag_link" body2: "pitch" point: {v(bearing)} axis: {v(axis_b)}
           initial_coordinate: {THETA0:.12g} }}
  joints {{ name: "swashplate" type: UNIVERSAL body1: "hub" body2: "pitch_link" point: {v(SWASH)} axis: [1, 0, 0] axis2: [0, 1, 0] }}
  joints {{ name: "apl" type: PRISMATIC body1: "pitch_link" body2: "apl" point: {v([PSX, PSY, 0.0])} axis: [0, 0, 1]
           locked: true lock_at_closure: true }}
  # The cut joint: the APL's top on the horn tip, by offsets in each body's frame (the closure
  # moves the horn tip's partner there: at 1.93° and 1.5° the tip is at {v(tip_closed)}).
  joints {{ name: "horn" type: SPHERICAL body1: "apl" body2: "pitch" point1: [0, 0, 0] point2: {v(horn_offset)} }}
{blade}
  # Table 8's pitch is held while the loop closes (the APL's length is what closes it); in the
  # run the pitch link sets the pitch, never a lock.
  initial_conditions {{ hold_joints: ["pitch_bearing"] }}
  air {{
    rotors {{ name: "rotor" hub: "hub" axis: [0, 0, 1] radius: {RADIUS} inflow: UNIFORM surfaces: ["blade_air"] blades: 4 }}
    surfaces {{ name: "blade_air" {SURFACE} }}
  }}
}}
numerics {{
  end_time: {TAU + T_FULL:g}
  step: 1e-4
  smooth {{ rho_inf: 0.95 }}
}}
output {{
  every: 10
  probes {{ name: "hub_speed" quantity: JOINT_SPEED entity: "shaft" }}
  probes {{ name: "flap" quantity: JOINT_COORDINATE entity: "flap" scale: 57.29577951308232 }}
  probes {{ name: "lag" quantity: JOINT_COORDINATE entity: "lag" scale: 57.29577951308232 }}
  probes {{ name: "pitch" quantity: JOINT_COORDINATE entity: "pitch_bearing" scale: 57.29577951308232 }}
  probes {{ name: "pitch_link_z_mm" quantity: POSITION entity: "apl" component: Z frame: "hub" scale: 1000 }}
  probes {{ name: "pitch_link_force" quantity: REACTION_FORCE entity: "apl" component: Z frame: "hub" }}
  probes {{ name: "cut_force_x" quantity: REACTION_FORCE entity: "horn" component: X frame: "hub" }}
  probes {{ name: "cut_force_y" quantity: REACTION_FORCE entity: "horn" component: Y frame: "hub" }}
  probes {{ name: "cut_force_z" quantity: REACTION_FORCE entity: "horn" component: Z frame: "hub" }}
  probes {{ name: "cut_moment" quantity: REACTION_MOMENT entity: "horn" component: NORM }}
{root_probes}
  probes {{ name: "thrust" quantity: ROTOR_THRUST entity: "rotor" }}
  probes {{ name: "induced_velocity" quantity: INDUCED_VELOCITY entity: "rotor" }}
  probes {{ name: "violation" quantity: CONSTRAINT_VIOLATION }}
}}
{STUDY}"""
print(header + body, end="")
