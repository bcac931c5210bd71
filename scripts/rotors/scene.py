"""Writes a rotor (rotors.spec.Rotor) as a folder of scenario files, the way a rotor engineer writes
one: named parameters, the hub's frame and one frame per blade, the blade written once and
included into a pattern, section and aerodynamic tables in CSV files.

  rotor.pbtxt              co-simulated stops: a contact node per stop pad, tied to the body that
                           carries it, against droop and anti-flap planes, in nonsmooth_solver
                           processes (one per blade, or one for the rotor)
  rotor_continuous.pbtxt   its continuous twin: the same stops as Hunt–Crossley laws in the
                           smooth model (joint stops on the flap or teeter hinge; contact forces on
                           a hingeless blade's pad), the nodes' masses kept on the bodies
  blade_parts.pbtxt        the blade both scenes share (hinges, bodies or beam, air)
  blade_stops.pbtxt        the co-simulated blade's stop pad and planes; blade_twin.pbtxt the twin's
  blade_sections.csv       a beam blade's section table (with the root and tip steps)
  air_stations.csv         the aerodynamic stations (chord, collective plus linear twist)
  rotor.json               the numbers (Rotor) the files were written from

Geometry: the shaft is the hub frame's z axis, the rotor turns counter-clockwise seen from
above (Ω > 0), each blade's frame `root{k}` has x along the blade and y towards its leading
edge, and a flap up is positive (hinge axes −y). Blades start drooped onto their droop stops
(slow starts), teetered level, or (a start at full speed) a little coned, off their stops.
"""
import dataclasses
import json
import math
import os

from rotors.spec import Rotor, twin_contact_duration

G = 9.81


def num(x):
    return f"{x:.10g}"


def vec(*xs):
    return "[" + ", ".join(num(x) for x in xs) + "]"


def node_offset(x0, z0, beta):
    """A point (x0, 0, z0) of a hinge's child turned by the flap angle beta (about −y)."""
    return (x0 * math.cos(beta) - z0 * math.sin(beta), x0 * math.sin(beta) + z0 * math.cos(beta))


def radial(x, z):
    """The terms of the radial distance of a point (x, 0, z) of the drooped frame (flap angle
    beta0): x cos(beta0) − z sin(beta0), as an expression to add."""
    out = f" + {num(x)} * cos(beta0)" if x >= 0 else f" - {num(-x)} * cos(beta0)"
    if z != 0:
        out += f" + {num(-z)} * sin(beta0)" if z < 0 else f" - {num(z)} * sin(beta0)"
    return out


# The drooped flap frame's angular velocity, and the speed of its point (x, 0, z) (radial(x, z)):
# the initial velocities of everything an articulated blade's flap hinge carries.
FLAP_SPIN = "[${-Omega0 * sin(-beta0)}, 0, ${Omega0 * cos(-beta0)}]"


def flap_speed(x, z=0.0):
    return f"${{Omega0 * (h0 + d{radial(x, z)})}}"


def plane_normals(x0, z0, lower, upper):
    """Normals of the two planes through the hinge's axis that the point (x0, z0) meets at the
    angles lower (< 0, droop) and upper (> 0, anti-flap); the point lies on their positive sides
    between them."""
    xd, zd = node_offset(x0, z0, lower)
    xu, zu = node_offset(x0, z0, upper)
    return (-zd, 0.0, xd), (zu, 0.0, -xu)


class Writer:
    def __init__(self, rotor: Rotor, twin_refinement=1):
        self.r = rotor
        r = rotor
        # The judge's refined twins (rotors/check.py): the twin's stop laws last contact_duration
        # / twin_refinement, at a step that many times smaller (output on the rotor's own steps).
        self.refinement = twin_refinement
        self.omega0 = {"gust": r.idle_fraction * r.omega, "engage": 0.0, "shutdown": r.omega}[r.excitation]
        self.spinning_start = self.omega0 > 0.3 * r.omega
        # Start angle of the flap (or teeter) hinge.
        if r.topology == "teetering":
            self.beta0 = 0.0
        elif self.spinning_start:
            self.beta0 = 0.3 * r.antiflap
        else:
            self.beta0 = r.droop
        self.hinge_d = r.flap_offset - r.lag_offset if r.has_lag() else 0.0  # lag → flap hinge
        self.cuff_length = r.pitch_radius() - r.flap_offset
        m_blade = r.blade_mass()
        self.cuff_mass = max(0.04 * m_blade, 2.0 * r.node_mass)
        self.lag_mass = 0.01 * m_blade
        self.fitting_mass = 0.01 * m_blade
        self.pad = (0.8 * self.cuff_length, -0.012 * r.radius)  # on the cuff, below the blade axis

    # Pieces ------------------------------------------------------------------------------
    def flap_inertia(self):
        """The blade's (and cuff's) flap inertia about the flap or teeter hinge [kg m²]."""
        r = self.r
        s1, s2 = r.blade_moments()
        d = r.blade_root() - (r.flap_offset if r.topology == "articulated" else 0.0)
        m = r.blade_mass()
        return s2 + 2 * d * s1 + d * d * m + self.cuff_mass * self.cuff_length**2 / 3

    def stop_stiffness(self, inertia, speed=1.0):
        """Hunt–Crossley K of a contact lasting about r.contact_duration at the onset speed
        `speed` for an effective inertia (Hertz: T = 3.21 (m² / (K² v))^(1/5))."""
        return inertia * (3.21 / self.r.contact_duration) ** 2.5 / math.sqrt(speed)

    def twin_stop_stiffness(self, inertia):
        """The twin's flap, teeter or pad stop: a contact lasting contact_duration / refinement
        (the lag stops, the same law in both scenes, keep contact_duration)."""
        return self.stop_stiffness(inertia) * self.refinement**2.5

    def parameters(self, twin):
        r = self.r
        p = [
            ("R", r.radius, "m", "rotor radius"),
            ("blades", r.blades, "", "number of blades"),
            ("Omega0", self.omega0, "rad/s", "rotor speed at the start (counter-clockwise from above)"),
            ("Omega", r.omega, "rad/s", "nominal rotor speed"),
            ("beta0", self.beta0, "rad", "flap (teeter) angle at the start"),
            ("droop", r.droop, "rad", "droop stop"),
            ("antiflap", r.antiflap, "rad", "anti-flap stop"),
            ("restitution", r.restitution, "", "Newton's restitution of the stops"),
        ]
        if r.topology == "articulated":
            p += [
                ("e", r.flap_offset, "m", "flap hinge offset"),
                ("h0", r.hinge_radius(), "m", "the blade's first hinge from the shaft"),
                ("d", self.hinge_d, "m", "lag hinge to flap hinge"),
                ("cuff_mass", self.cuff_mass, "kg", "flap hinge to pitch bearing"),
            ]
        p += [("node_mass", r.node_mass, "kg", "stop pad (contact node)")]
        if not twin:
            p += [("c_tie", r.regularization, "m/N", "")]
        return "\n".join(
            f'parameters {{ name: "{n}" value: {num(v)}'
            + (f' unit: "{u}"' if u else "")
            + (f' description: "{d}"' if d else "")
            + " }"
            for n, v, u, d in p
        )

    def hub_drive(self):
        r = self.r
        if r.excitation == "gust":
            return "constant: ${Omega0}"
        if r.excitation == "engage":
            return f"cosine_ramp {{ final_value: ${{Omega}} ramp_time: {num(r.ramp_time)} start_time: 0.3 }}"
        return (
            "sum { terms { constant: ${Omega} } "
            f"terms {{ cosine_ramp {{ final_value: ${{-Omega}} ramp_time: {num(r.ramp_time)} start_time: 0.3 }} }} }}"
        )

    def air(self):
        r = self.r
        lines = []
        if r.excitation == "gust":
            a, w = r.gust_azimuth, r.gust_upwash
            h = math.sqrt(1 - w * w)
            o = r.radius + 3
            lines.append(
                f"    gusts {{ front_direction: {vec(math.cos(a), math.sin(a), 0)} direction: {vec(h * math.cos(a), h * math.sin(a), w)}\n"
                f"            front_speed: {num(r.gust_front_speed)} front_origin: {vec(-o * math.cos(a), -o * math.sin(a), 0)}\n"
                f"            profile {{ cosine_pulse {{ peak: {num(r.gust_peak)} duration: {num(r.gust_length)} }} }} }}"
            )
        else:
            lines.append(
                f"    wind_x {{ constant: {num(r.wind * math.cos(r.wind_azimuth))} }} "
                f"wind_y {{ constant: {num(r.wind * math.sin(r.wind_azimuth))} }}"
            )
        lines.append(
            '    rotors { name: "rotor" reference: "hub" hub: "hub" axis: [0, 0, 1] radius: ${R} inflow: UNIFORM'
            ' surfaces: ["blade{blades}"] }'
        )
        return "  air {\n" + "\n".join(lines) + "\n  }"

    def sections_csv(self):
        r = self.r
        if r.sections_csv:
            with open(r.sections_csv) as f:
                return f.read()
        r0, R = r.blade_root(), r.radius
        root_end = r0 + r.root_fraction * (R - r0)
        tip_start = R - 0.05 * (R - r0)
        rows = ["# The blade's sections: radius s [m], the rest per BeamStation (SI); a step at the root's end"]
        rows.append("# and at the tip weight (two stations at one s).")
        rows.append("s,ea,gj,ei_flap,ei_lag,mass,inertia_torsion")
        for s, side in ((r0, 0), (root_end, -1), (root_end, 1), (tip_start, -1), (tip_start, 1), (R, 0)):
            probe = s - 1e-9 if side < 0 else s + 1e-9 if side > 0 else s
            m, ef, el, gj, ea = r.section(min(max(probe, r0), R - 1e-9) if side >= 0 else probe)
            rows.append(",".join(num(x) for x in (s, ea, gj, ef, el, m, m * (0.3 * r.chord) ** 2 / 12)))
        return "\n".join(rows) + "\n"

    def air_csv(self):
        r = self.r
        start = 0.2 * r.radius
        offset = 0.0 if r.blade_model == "beam" else r.blade_root()  # a rigid blade's s runs from its root
        rows = [
            "# Aerodynamic stations: s [m] (a beam's radius, a rigid blade's distance from its root),",
            "s,chord,twist,airfoil",
        ]
        for f in (0.0, 0.5, 1.0):
            s = start + f * (r.radius - start)
            rows.append(f"{num(s - offset)},{num(r.chord)},{num(r.collective + r.twist * f)},naca0012")
        return "\n".join(rows) + "\n"

    # The blade: articulated ------------------------------------------------------------------
    def articulated_parts(self):
        r = self.r
        L = self.cuff_length
        th = "${-beta0}"  # the drooped frame's rotation about y
        out = ['references { name: "root{k}" reference: "hub" position: [${h0}, 0, 0] }']
        out.append(
            f'  references {{ name: "flap{{k}}" reference: "root{{k}}" position: [${{d}}, 0, 0] rotation: [0, {th}, 0] }}'
        )
        parent = "hub"
        if r.has_lag():
            parent = "lag{k}"
            out.append(
                f'  bodies {{ name: "lag{{k}}" reference: "root{{k}}" mass: {num(self.lag_mass)} inertia: [1e-3, 1e-3, 1e-3]'
                f" position: [${{d / 2}}, 0, 0] velocity: [0, ${{Omega0 * (h0 + d / 2)}}, 0] angular_velocity: [0, 0, ${{Omega0}}] }}"
            )
            out.append(
                '  joints { name: "lag{k}_hinge" reference: "root{k}" type: REVOLUTE body1: "hub" body2: "lag{k}" point: [0, 0, 0] axis: [0, 0, 1] }'
            )
            out.append(
                f'  forces {{ name: "lag{{k}}_damper" joint_spring {{ joint: "lag{{k}}_hinge" stiffness: 0 damping: {num(r.lag_damping)} }} }}'
            )
            if r.lag_stop > 0:
                k_lag = self.stop_stiffness(r.blade_moments()[1])
                out.append(
                    f'  forces {{ name: "lag{{k}}_stops" joint_stop {{ joint: "lag{{k}}_hinge" lower: {num(-r.lag_stop)} upper: {num(r.lag_stop)}\n'
                    f"           law {{ stiffness: {num(k_lag)} exponent: 1.5 restitution: 0.5 effective_restitution: true }} }} }}"
                )
        cuff_i = self.cuff_mass * L * L / 12 + 1e-3
        out.append(
            f'  bodies {{ name: "cuff{{k}}" reference: "flap{{k}}" mass: ${{cuff_mass}} inertia: [1e-3, {num(cuff_i)}, {num(cuff_i)}]'
            f" position: [{num(L / 2)}, 0, 0] velocity: [0, {flap_speed(L / 2)}, 0] angular_velocity: {FLAP_SPIN} }}"
        )
        out.append(
            f'  joints {{ name: "flap{{k}}_hinge" reference: "root{{k}}" type: REVOLUTE body1: "{parent}" body2: "cuff{{k}}"'
            " point: [${d}, 0, 0] axis: [0, -1, 0] initial_coordinate: ${beta0} }"
        )
        carrier = "blade{k}" if r.blade_model == "rigid" else "pitch{k}"
        if r.blade_model == "rigid":
            out.append(self.rigid_blade("flap{k}", L, flap_speed, FLAP_SPIN))
        else:
            out.append(
                f'  bodies {{ name: "pitch{{k}}" reference: "flap{{k}}" mass: {num(self.fitting_mass)} inertia: [1e-3, 1e-3, 1e-3]'
                f" position: [{num(L)}, 0, 0] velocity: [0, {flap_speed(L)}, 0] angular_velocity: {FLAP_SPIN} }}"
            )
            out.append(self.beam("flap{k}", L, "pitch{k}", flap_speed(L), FLAP_SPIN))
        locked = " locked: true" if r.pitch == "locked" else ""
        out.append(
            f'  joints {{ name: "pitch{{k}}_bearing" reference: "flap{{k}}" type: REVOLUTE body1: "cuff{{k}}" body2: "{carrier}"'
            f" point: [{num(L)}, 0, 0] axis: [1, 0, 0]{locked} }}"
        )
        if r.pitch == "link":
            # Horn on the flap hinge's axis (flapping does not pitch the blade), a link straight down
            # to the swashplate (a point of the hub: zero collective and cyclic).
            hh, lp = 0.35 * r.chord, 0.04 * r.radius
            out.append(
                f'  bodies {{ name: "link{{k}}" reference: "root{{k}}" mass: {num(0.005 * r.blade_mass())} inertia: [1e-3, 1e-3, 1e-4]'
                f" position: [${{d}}, {num(-hh)}, {num(-lp / 2)}] velocity: [0, ${{Omega0 * (h0 + d)}}, 0] angular_velocity: [0, 0, ${{Omega0}}] }}"
            )
            out.append(
                f'  joints {{ name: "horn{{k}}" reference: "root{{k}}" type: SPHERICAL body1: "{carrier}" body2: "link{{k}}" point: [${{d}}, {num(-hh)}, 0] }}'
            )
            out.append(
                f'  joints {{ name: "swashplate{{k}}" reference: "root{{k}}" type: UNIVERSAL body1: "hub" body2: "link{{k}}"'
                f" point: [${{d}}, {num(-hh)}, {num(-lp)}] axis: [1, 0, 0] axis2: [0, 1, 0] }}"
            )
        out.append(self.surface("flap{k}", L))
        return "\n".join(out) + "\n"

    def rigid_blade(self, frame, x0, speed, w):
        """A rigid blade from x0 along its frame's x: its mass, centre and inertia from the sections;
        speed(x) is the expression of the speed of its frame's point x."""
        r = self.r
        m = r.blade_mass()
        s1, s2 = r.blade_moments()
        xg = s1 / m
        iyy = s2 - m * xg * xg
        return (
            f'  bodies {{ name: "blade{{k}}" reference: "{frame}" mass: {num(m)} inertia: [{num(m * r.chord**2 / 60)}, {num(iyy)}, {num(iyy)}]'
            f" position: [{num(x0 + xg)}, 0, 0] velocity: [0, {speed(x0 + xg)}, 0] angular_velocity: {w} }}"
        )

    def beam(self, frame, x0, root_body, root_speed, w):
        r = self.r
        return (
            f'  beams {{ name: "blade{{k}}" reference: "{frame}" root: [{num(x0)}, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0]\n'
            f"          span_start: {num(r.blade_root())} span_end: ${{R}} elements: {r.elements} nodes_per_element: {r.nodes_per_element}\n"
            f'          retardation_time: {num(r.retardation_time)} root_body: "{root_body}" stations_file: "blade_sections.csv"\n'
            f"          velocity: [0, {root_speed}, 0] angular_velocity: {w} }}"
        )

    def surface(self, frame, x0):
        if self.r.blade_model == "beam":
            carrier = 'beam: "blade{k}"'
            geometry = ""
        else:
            carrier = 'body: "blade{k}"'
            geometry = f" root: [{num(x0)}, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] segments: 8"
        return (
            f'  air {{ surfaces {{ name: "blade{{k}}" reference: "{frame}" {carrier}{geometry} upper: [0, 0, 1]'
            ' stations_file: "air_stations.csv" } }'
        )

    def articulated_stops(self, twin):
        r = self.r
        x0, z0 = self.pad
        L = self.cuff_length
        if twin:
            # The pad's mass where the co-simulated model has it, on the cuff at the pad (folded
            # into the cuff's mass at the cuff's centre, on the blade axis, it lacked the pad's
            # centrifugal moment about the flap hinge, 0.034 m below it: rotor 582's 7 kg pads
            # flapped 0.8° RMS apart in the two models before any contact).
            k = self.twin_stop_stiffness(self.flap_inertia())
            return (
                f'  bodies {{ name: "pad{{k}}" reference: "flap{{k}}" mass: ${{node_mass}} inertia: [1e-4, 1e-4, 1e-4] position: [{num(x0)}, 0, {num(z0)}]\n'
                f"          velocity: [0, {flap_speed(x0, z0)}, 0] angular_velocity: {FLAP_SPIN} }}\n"
                f'  joints {{ name: "pad{{k}}_mount" reference: "flap{{k}}" type: FIXED body1: "cuff{{k}}" body2: "pad{{k}}" point: [{num(x0)}, 0, {num(z0)}] }}\n'
                '  forces { name: "stops{k}" joint_stop { joint: "flap{k}_hinge" lower: ${droop} upper: ${antiflap}\n'
                f"           law {{ stiffness: {num(k)} exponent: 1.5 restitution: {num(max(r.restitution, 0.05))} effective_restitution: true }} }} }}\n",
                "",
            )
        dn, un = plane_normals(x0, z0, r.droop, r.antiflap)
        carrier = "lag{k}" if r.has_lag() else "hub"
        return (
            f'  contact_nodes {{ name: "pad{{k}}" reference: "flap{{k}}" mass: ${{node_mass}} position: [{num(x0)}, 0, {num(z0)}]\n'
            f"                  velocity: [0, {flap_speed(x0, z0)}, 0]\n"
            '                  contacts { obstacle: "droop{k}" restitution: ${restitution} } contacts { obstacle: "antiflap{k}" restitution: ${restitution} } }\n'
            f'  obstacles {{ name: "droop{{k}}" reference: "root{{k}}" point: [${{d}}, 0, 0] normal: {vec(*dn)} attached_to_body: "{carrier}" }}\n'
            f'  obstacles {{ name: "antiflap{{k}}" reference: "root{{k}}" point: [${{d}}, 0, 0] normal: {vec(*un)} attached_to_body: "{carrier}" }}\n',
            f'  interface_nodes {{ contact_node: "pad{{k}}" body: "cuff{{k}}" point: [{num(x0 - L / 2)}, 0, {num(z0)}] regularization: ${{c_tie}} }}\n',
        )

    # Teetering -----------------------------------------------------------------------------
    def teetering_parts(self):
        r = self.r
        r0 = r.blade_root()
        w = "[${Omega0 * sin(precone)}, 0, ${Omega0 * cos(precone)}]"
        out = ['references { name: "root{k}" reference: "hub" position: [0, 0, ${-u}] rotation: [0, ${-precone}, 0] }']
        if r.blade_model == "rigid":
            out.append(self.rigid_blade("root{k}", r0, lambda x: f"${{Omega0 * {num(x)} * cos(precone)}}", w))
            lock = " locked: true" if r.pitch == "locked" else ""
            kind = "REVOLUTE" if lock else "FIXED"
            out.append(
                f'  joints {{ name: "pitch{{k}}_bearing" reference: "root{{k}}" type: {kind} body1: "yoke" body2: "blade{{k}}" point: [{num(r0)}, 0, 0] axis: [1, 0, 0]{lock} }}'
            )
        else:
            out.append(self.beam("root{k}", r0, "yoke", f"${{Omega0 * {num(r0)} * cos(precone)}}", w))
        out.append(self.surface("root{k}", r0))
        return "\n".join(out) + "\n"

    def teetering_hub(self, twin):
        """The yoke, the teeter hinge and (co-simulated) the two pads with their mast planes, or
        (twin) the teeter stops: outside the pattern (one yoke carries both pads)."""
        r = self.r
        my = 0.15 * r.blade_mass()
        out = [
            f'  bodies {{ name: "yoke" reference: "hub" mass: {num(my)} inertia: [{num(0.6 * my * r.pad_arm**2)}, {num(my * r.pad_arm**2)}, {num(1.5 * my * r.pad_arm**2)}]'
            " position: [0, 0, ${-u}] angular_velocity: [0, 0, ${Omega0}] }",
            '  joints { name: "teeter" reference: "hub" type: REVOLUTE body1: "hub" body2: "yoke" point: [0, 0, 0] axis: [0, -1, 0] }',
        ]
        zp = -(r.undersling + 0.01 * r.radius)  # pads below the yoke, relative to the teeter hinge
        if twin:
            # The pads' masses where the co-simulated model has them (they were folded into the
            # yoke's mass at its centre, 0.01 R above them and without their teeter inertia).
            for k, sign in ((1, 1.0), (2, -1.0)):
                x = sign * r.pad_arm
                out.append(
                    f'  bodies {{ name: "pad{k}" reference: "hub" mass: ${{node_mass}} inertia: [1e-4, 1e-4, 1e-4] position: [{num(x)}, 0, {num(zp)}]'
                    f" velocity: [0, ${{Omega0 * {num(x)}}}, 0] angular_velocity: [0, 0, ${{Omega0}}] }}"
                )
                out.append(
                    f'  joints {{ name: "pad{k}_mount" reference: "hub" type: FIXED body1: "yoke" body2: "pad{k}" point: [{num(x)}, 0, {num(zp)}] }}'
                )
            k = self.twin_stop_stiffness(2 * self.flap_inertia())
            out.append(
                '  forces { name: "stops" joint_stop { joint: "teeter" lower: ${droop} upper: ${antiflap}\n'
                f"           law {{ stiffness: {num(k)} exponent: 1.5 restitution: {num(max(r.restitution, 0.05))} effective_restitution: true }} }} }}"
            )
            return "\n".join(out), ""
        dn, _ = plane_normals(r.pad_arm, zp, r.droop, r.antiflap)
        coupling = []
        for k, sign in ((1, 1.0), (2, -1.0)):
            x = sign * r.pad_arm
            normal = (sign * dn[0], 0.0, dn[2])
            out.append(
                f'  contact_nodes {{ name: "pad{k}" reference: "hub" mass: ${{node_mass}} position: [{num(x)}, 0, {num(zp)}]'
                f" velocity: [0, ${{Omega0 * {num(x)}}}, 0]\n"
                f'                  contacts {{ obstacle: "mast{k}" restitution: ${{restitution}} }} }}'
            )
            out.append(
                f'  obstacles {{ name: "mast{k}" reference: "hub" point: [0, 0, 0] normal: {vec(*normal)} attached_to_body: "hub" }}'
            )
            coupling.append(
                f'  interface_nodes {{ contact_node: "pad{k}" body: "yoke" point: [{num(x)}, 0, {num(zp + r.undersling)}] regularization: ${{c_tie}} }}'
            )
        return "\n".join(out), "\n".join(coupling)

    # Hingeless -----------------------------------------------------------------------------
    def pad_node(self):
        """The beam node that carries a hingeless blade's pad: the one nearest 30 % of the span."""
        r = self.r
        n = r.elements * (r.nodes_per_element - 1)
        j = max(1, round(0.3 * n))
        return j, r.blade_root() + j * (r.radius - r.blade_root()) / n

    def hingeless_parts(self):
        out = ['references { name: "root{k}" reference: "hub" position: [${R0}, 0, 0] }']
        out.append(self.beam("root{k}", 0.0, "hub", "${Omega0 * R0}", "[0, 0, ${Omega0}]"))
        out.append(self.surface("root{k}", 0.0))
        return "\n".join(out) + "\n"

    def hingeless_gap(self):
        """The anti-flap plane's height above the pad: a share of the blade's static sag there."""
        r = self.r
        j, s = self.pad_node()
        L, x = r.radius - r.blade_root(), s - r.blade_root()
        sag = (
            r.mass_per_length * G * x * x * (6 * L * L - 4 * L * x + x * x) / (24 * r.ei_flap * r.root_stiffness_factor)
        )
        # 2–6 times the sag: a gust of one to a few g lifts the pad onto it; never under 5 mm.
        return max(sag * (2 + 4 * (r.hingeless_gap_up / r.radius - 0.01) / 0.03), 5e-3)

    def hingeless_stops(self, twin):
        r = self.r
        j, s = self.pad_node()
        x = s - r.blade_root()
        gap = self.hingeless_gap()
        planes = (
            f'  obstacles {{ name: "droop{{k}}" reference: "root{{k}}" point: [{num(x)}, 0, 0] normal: [0, 0, 1] attached_to_body: "hub" }}\n'
            f'  obstacles {{ name: "antiflap{{k}}" reference: "root{{k}}" point: [{num(x)}, 0, {num(gap)}] normal: [0, 0, -1] attached_to_body: "hub" }}\n'
        )
        if twin:
            k = self.twin_stop_stiffness(0.25 * r.blade_mass())
            law = f"law {{ stiffness: {num(k)} exponent: 1.5 restitution: {num(max(r.restitution, 0.05))} effective_restitution: true }}"
            return (
                planes
                + f'  bodies {{ name: "pad{{k}}" reference: "root{{k}}" mass: {num(r.node_mass)} inertia: [1e-4, 1e-4, 1e-4]'
                f" position: [{num(x)}, 0, 0] velocity: [0, ${{Omega0 * (R0 + {num(x)})}}, 0] angular_velocity: [0, 0, ${{Omega0}}] }}\n"
                f'  joints {{ name: "pad{{k}}_mount" reference: "root{{k}}" type: FIXED body1: "blade{{k}}.n{j}" body2: "pad{{k}}" point: [{num(x)}, 0, 0] }}\n'
                f'  forces {{ name: "stops{{k}}_droop" continuous_contact {{ body: "pad{{k}}" point: [0, 0, 0] obstacle: "droop{{k}}" {law} }} }}\n'
                f'  forces {{ name: "stops{{k}}_antiflap" continuous_contact {{ body: "pad{{k}}" point: [0, 0, 0] obstacle: "antiflap{{k}}" {law} }} }}\n',
                "",
            )
        return (
            planes
            + f'  contact_nodes {{ name: "pad{{k}}" reference: "root{{k}}" mass: ${{node_mass}} position: [{num(x)}, 0, 0]'
            f" velocity: [0, ${{Omega0 * (R0 + {num(x)})}}, 0]\n"
            '                  contacts { obstacle: "droop{k}" restitution: ${restitution} } contacts { obstacle: "antiflap{k}" restitution: ${restitution} } }\n',
            f'  interface_nodes {{ contact_node: "pad{{k}}" body: "blade{{k}}.n{j}" point: [0, 0, 0] regularization: ${{c_tie}} }}\n',
        )

    # Probes --------------------------------------------------------------------------------
    def blade_probes(self, twin):
        r = self.r
        out = []
        if r.topology == "articulated":
            out.append(
                'probes { name: "flap{k}" quantity: JOINT_COORDINATE entity: "flap{k}_hinge" scale: 57.29577951308232 }'
            )
            if r.has_lag():
                out.append(
                    'probes { name: "lag{k}" quantity: JOINT_COORDINATE entity: "lag{k}_hinge" scale: 57.29577951308232 }'
                )
        elif r.topology == "hingeless":
            j, _ = self.pad_node()
            out.append(f'probes {{ name: "flap{{k}}" quantity: POSITION entity: "blade{{k}}.n{j}" component: Z }}')
        if r.topology != "teetering":
            if twin:
                if r.topology == "articulated":
                    out.append('probes { name: "stop{k}" quantity: CONTACT_FORCE entity: "stops{k}" }')
                else:
                    out.append('probes { name: "stop{k}_droop" quantity: CONTACT_FORCE entity: "stops{k}_droop" }')
                    out.append(
                        'probes { name: "stop{k}_antiflap" quantity: CONTACT_FORCE entity: "stops{k}_antiflap" }'
                    )
            else:
                out.append('probes { name: "stop{k}_droop" quantity: IMPULSE entity: "pad{k}/droop{k}" }')
                out.append('probes { name: "stop{k}_antiflap" quantity: IMPULSE entity: "pad{k}/antiflap{k}" }')
        return "\n".join(out) + "\n"

    def rotor_probes(self, twin):
        r = self.r
        out = ['probes { name: "hub_speed" quantity: JOINT_SPEED entity: "shaft" }']
        if r.topology == "teetering":
            out.append('probes { name: "teeter" quantity: JOINT_COORDINATE entity: "teeter" scale: 57.29577951308232 }')
            if twin:
                out.append('probes { name: "stop" quantity: CONTACT_FORCE entity: "stops" }')
            else:
                for k in (1, 2):
                    out.append(f'probes {{ name: "stop{k}_mast" quantity: IMPULSE entity: "pad{k}/mast{k}" }}')
        return "\n".join("  " + p for p in out)

    # Files ---------------------------------------------------------------------------------
    def scene(self, twin):
        r = self.r
        kind = "continuous twin" if twin else "co-simulated stops"
        head = [
            f"# Generated by scripts/cosim rotor ({r.name}; the numbers in rotor.json): a {r.blades}-blade {r.topology} rotor,",
            f"# {r.blade_model} blades, R = {num(r.radius)} m, {kind}, {r.excitation}. Edit freely: it is a scene like any other.",
            f'name: "{r.name}{"_continuous" if twin else ""}"',
            f'description: "{r.blades}-blade {r.topology} rotor, {r.blade_model} blades, {r.excitation}, {kind}"',
            self.parameters(twin),
        ]
        if r.topology == "teetering":
            head.append(f'parameters {{ name: "u" value: {num(r.undersling)} unit: "m" description: "undersling" }}')
            head.append(f'parameters {{ name: "precone" value: {num(r.precone)} unit: "rad" }}')
        if r.topology == "hingeless":
            head.append(
                f'parameters {{ name: "R0" value: {num(r.root_radius)} unit: "m" description: "blade root (clamp) radius" }}'
            )
        model = [
            "model {",
            "  gravity: [0, 0, -9.81]",
            '  references { name: "hub" position: [0, 0, 0] }',
            f'  bodies {{ name: "hub" reference: "hub" mass: {num(r.hub_mass)} inertia: [{num(r.hub_mass * 0.02)}, {num(r.hub_mass * 0.02)}, {num(r.hub_mass * 0.04)}]'
            " angular_velocity: [0, 0, ${Omega0}] }",
            '  joints { name: "shaft" reference: "hub" type: REVOLUTE body1: "ground" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]',
            f"           drive {{ quantity: ANGULAR_SPEED function {{ {self.hub_drive()} }} }} }}",
        ]
        coupling_extra = ""
        if r.topology == "teetering":
            hub, coupling_extra = self.teetering_hub(twin)
            model.append(hub)
        model.append(self.air())
        model.append("}")
        model_files = ["blade_parts.pbtxt", "blade_twin.pbtxt" if twin else "blade_stops.pbtxt"]
        each = ["    model {", *[f'      include: "{f}"' for f in model_files], "    }"]
        if not twin and r.topology != "teetering":
            each += ["    coupling {", '      include: "blade_coupling.pbtxt"', "    }"]
        each += [
            "    output {",
            f'      include: "{"blade_probes_twin.pbtxt" if twin else "blade_probes.pbtxt"}"',
            "    }",
        ]
        pattern = [
            "patterns {",
            '  name: "blades"',
            "  count: ${blades}",
            '  reference: "hub"  # the copies turn about the hub frame\'s z axis: tilt the frame, tilt the rotor',
            "  axis: [0, 0, 1]",
            "  each {",
            *each,
            "  }",
            "}",
        ]
        tail = []
        if not twin:
            processes = []
            if r.processes == "rotor":
                processes.append('  processes { name: "stops" contact_nodes: ["pad{blades}"] }')
            elif r.topology == "teetering":
                processes.append('  processes { name: "stops1" contact_nodes: ["pad1"] }')
                processes.append('  processes { name: "stops2" contact_nodes: ["pad2"] }')
            tail.append("coupling {\n" + "\n".join(processes + ([coupling_extra] if coupling_extra else [])) + "\n}")
        settle = " smooth { settle: true }" if r.settle else ""
        f = self.refinement if twin else 1
        tail.append(f"numerics {{ end_time: {num(r.end_time)} step: {num(r.step / f)}{settle} }}")
        tail.append(f"output {{\n  every: {f}\n" + self.rotor_probes(twin) + "\n}")
        return "\n".join(head + model + pattern + tail) + "\n"

    def blade_stops(self, twin):
        """(model entries, coupling entries) of one blade's stops."""
        r = self.r
        if r.topology == "articulated":
            model, coupling = self.articulated_stops(twin)
        elif r.topology == "hingeless":
            model, coupling = self.hingeless_stops(twin)
        else:
            return "# The pads and the mast's planes are the yoke's, in rotor.pbtxt.\n", ""
        if not twin and r.processes == "blade":
            coupling += '  processes { name: "stops{k}" contact_nodes: ["pad{k}"] }\n'
        return model, coupling

    def parts(self):
        r = self.r
        if r.topology == "articulated":
            return self.articulated_parts()
        if r.topology == "teetering":
            return self.teetering_parts()
        return self.hingeless_parts()


def complete(rotor: Rotor):
    """The rotor as written: refused naming the field if it makes none, its twin's contact time set."""
    problems = rotor.check()
    if problems:
        raise ValueError("; ".join(problems))
    if rotor.contact_duration <= 0.0:  # (the judge reads the law's time from rotor.json)
        rotor = dataclasses.replace(rotor, contact_duration=twin_contact_duration(rotor.topology))
    return rotor


def put(folder, files):
    os.makedirs(folder, exist_ok=True)
    for name, text in files.items():
        with open(os.path.join(folder, name), "w") as f:
            f.write(text)


def twin_files(w: Writer):
    """The files the continuous twin reads, by name."""
    files = {
        "rotor_continuous.pbtxt": w.scene(True),
        "blade_parts.pbtxt": w.parts(),
        "blade_twin.pbtxt": w.blade_stops(True)[0],
        "blade_probes_twin.pbtxt": w.blade_probes(True),
        "air_stations.csv": w.air_csv(),
    }
    if w.r.blade_model == "beam":
        files["blade_sections.csv"] = w.sections_csv()
    return files


def write(rotor: Rotor, folder):
    """Writes the rotor's files into `folder` (made if needed); returns the two scenes' paths."""
    rotor = complete(rotor)
    w = Writer(rotor)
    files = {
        "rotor.pbtxt": w.scene(False),
        "blade_stops.pbtxt": w.blade_stops(False)[0],
        "blade_coupling.pbtxt": w.blade_stops(False)[1],
        "blade_probes.pbtxt": w.blade_probes(False),
        "rotor.json": json.dumps(dataclasses.asdict(rotor), indent=1) + "\n",
        **twin_files(w),
    }
    put(folder, files)
    return os.path.join(folder, "rotor.pbtxt"), os.path.join(folder, "rotor_continuous.pbtxt")


def write_refined_twin(rotor: Rotor, folder, refinement):
    """Writes only the continuous twin into `folder`, its flap, teeter or pad stops lasting
    contact_duration / refinement at a step `refinement` times smaller, its history on the
    rotor's own steps (rotors/check.py's refined twins); returns the scene's path."""
    put(folder, twin_files(Writer(complete(rotor), refinement)))
    return os.path.join(folder, "rotor_continuous.pbtxt")
