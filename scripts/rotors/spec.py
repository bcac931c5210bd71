"""A rotor as numbers (Rotor) and the seeded draw of one from physical ranges (draw).

Every number a scene needs is a field here, so that a generated rotor and a user's rotor
(scripts/cosim rotor new) go through the same writer (rotors/scene.py), and a rotor's file
rotor.json says what was drawn. Units: SI, angles in radians unless a name says deg.
"""
import dataclasses
import math
import random

TOPOLOGIES = ("articulated", "teetering", "hingeless")
EXCITATIONS = ("gust", "engage", "shutdown")


@dataclasses.dataclass
class Rotor:
    name: str = "rotor"
    topology: str = "articulated"
    blades: int = 4
    radius: float = 5.0  # R [m]
    chord: float = 0.35  # [m]
    blade_model: str = "rigid"  # rigid | beam
    # Section data (a beam's; a rigid blade takes its mass per length and root step only).
    mass_per_length: float = 6.0  # [kg/m] outboard
    ei_flap: float = 4e4  # [N m²]
    ei_lag: float = 6e5
    gj: float = 6e4
    ea: float = 1e8  # [N]
    root_fraction: float = 0.15  # share of the span from the root with a heavier, stiffer section (a step)
    root_mass_factor: float = 2.0
    root_stiffness_factor: float = 3.0
    tip_mass_factor: float = 1.0  # a tip weight over the last 5 % (1: none)
    # A user's section table (CSV with BeamStation's columns, s in radius from the blade root on)
    # used as it is instead of the steps above; its mass column gives the blade's mass.
    sections_csv: str = ""
    elements: int = 4
    nodes_per_element: int = 3
    retardation_time: float = 2e-4  # Kelvin–Voigt β [s]
    # Articulated hub.
    flap_offset: float = 0.2  # e [m] from the shaft
    lag_offset: float = 0.15  # lag hinge [m] (== flap_offset: coincident hinges; < 0: no lag hinge)
    lag_damping: float = 2000.0  # [N m s/rad]
    lag_stop: float = math.radians(15)  # ± [rad]; 0: none
    pitch: str = "locked"  # locked | link
    # Teetering hub.
    undersling: float = 0.1  # teeter hinge above the yoke's centre [m]
    precone: float = math.radians(2.75)
    pad_arm: float = 0.12  # pads' distance from the shaft along the yoke [m]
    # Hingeless hub: the beam clamped to the hub at this radius.
    root_radius: float = 0.3
    # Stops: droop (< 0) and anti-flap (> 0) angles of the flap hinge, the teeter hinge, or (hingeless)
    # the stop plane's height below/above the pad [m].
    droop: float = math.radians(-6)
    antiflap: float = math.radians(6)
    hingeless_gap_up: float = 0.03
    node_mass: float = 0.2  # [kg], taken from the body the node is tied to
    regularization: float = 5e-9  # Tikhonov c [m/N]; 0: a rigid tie
    processes: str = "blade"  # blade: one contact process per blade | rotor: one for all
    restitution: float = 0.5
    # The continuous twin's Hunt–Crossley contact time [s]; 0: the topology's (twin_contact_duration).
    contact_duration: float = 0.0
    # Rotor speed and excitation.
    omega: float = 40.0  # nominal [rad/s], counter-clockwise seen from above
    excitation: str = "gust"  # gust | engage | shutdown
    idle_fraction: float = 0.0  # gust: the rotor turns at this share of omega (0: still)
    gust_peak: float = 30.0  # [m/s]
    gust_azimuth: float = math.radians(90)  # the direction the gust blows towards
    gust_upwash: float = 0.2  # vertical share of the gust's direction
    gust_front_speed: float = 25.0
    gust_length: float = 60.0  # [m]
    wind: float = 10.0  # engage/shutdown: a steady wind [m/s]
    wind_azimuth: float = 0.0
    ramp_time: float = 3.0  # engage/shutdown [s]
    collective: float = math.radians(8)
    twist: float = math.radians(-8)  # root to tip
    settle: bool = False
    end_time: float = 3.0
    step: float = 1e-3
    hub_mass: float = 30.0

    # Derived geometry ------------------------------------------------------------------
    def has_lag(self):
        return self.topology == "articulated" and self.lag_offset >= 0

    def hinge_radius(self):
        """The radius of the blade's first joint to the hub (its frame's origin)."""
        if self.topology == "articulated":
            return self.lag_offset if self.has_lag() else self.flap_offset
        return self.root_radius if self.topology == "hingeless" else 0.0

    def pitch_radius(self):
        """The pitch bearing (articulated): the blade proper starts there."""
        return self.flap_offset + 0.035 * self.radius

    def blade_root(self):
        if self.topology == "articulated":
            return self.pitch_radius()
        if self.topology == "teetering":
            return self.pad_arm + 0.04 * self.radius
        return self.root_radius

    def section(self, s):
        """(mass, ei_flap, ei_lag, gj, ea) at radius s (the table's steps: root and tip)."""
        root_end = self.blade_root() + self.root_fraction * (self.radius - self.blade_root())
        m, k = 1.0, 1.0
        if s < root_end:
            m, k = self.root_mass_factor, self.root_stiffness_factor
        elif s >= self.radius - 0.05 * (self.radius - self.blade_root()):
            m = self.tip_mass_factor
        return (
            self.mass_per_length * m,
            self.ei_flap * k,
            self.ei_lag * k,
            self.gj * k,
            self.ea * k,
        )

    def table(self):
        """(s, mass per length) of the user's table, or None."""
        if not self.sections_csv:
            return None
        import csv

        with open(self.sections_csv) as f:
            rows = [r for r in csv.DictReader(line for line in f if not line.startswith("#"))]
        return [(float(r["s"]), float(r["mass"])) for r in rows]

    def table_moments(self):
        """Mass and first and second moments about the blade root of the user's table (linear
        between stations, constant beyond them, from blade_root to radius)."""
        pts = self.table()
        r0, R = self.blade_root(), self.radius
        xs = [r0 + (R - r0) * i / 400 for i in range(401)]

        def m_at(x):
            if x <= pts[0][0]:
                return pts[0][1]
            for (a, ma), (b, mb) in zip(pts, pts[1:]):
                if a <= x <= b:
                    return ma if b == a else ma + (mb - ma) * (x - a) / (b - a)
            return pts[-1][1]

        dx = (R - r0) / 400
        m = s1 = s2 = 0.0
        for a, b in zip(xs, xs[1:]):
            mid = 0.5 * (a + b)
            w = m_at(mid) * dx
            m, s1, s2 = m + w, s1 + w * (mid - r0), s2 + w * (mid - r0) ** 2
        return m, s1, s2

    def parts(self):
        """The blade's spans (from, to, mass factor): the root step, the middle, the tip weight."""
        r0, R = self.blade_root(), self.radius
        root_end = r0 + self.root_fraction * (R - r0)
        tip_start = R - 0.05 * (R - r0)
        return [(r0, root_end, self.root_mass_factor), (root_end, tip_start, 1.0), (tip_start, R, self.tip_mass_factor)]

    def blade_mass(self):
        """Mass from the blade root to the tip, with the steps."""
        if self.sections_csv:
            return self.table_moments()[0]
        return self.mass_per_length * sum(f * (b - a) for a, b, f in self.parts())

    def blade_moments(self):
        """First and second mass moments of the blade about its root (along the span)."""
        if self.sections_csv:
            return self.table_moments()[1:]
        r0, m = self.blade_root(), self.mass_per_length
        s1 = sum(m * f * ((b - r0) ** 2 - (a - r0) ** 2) / 2 for a, b, f in self.parts())
        s2 = sum(m * f * ((b - r0) ** 3 - (a - r0) ** 3) / 3 for a, b, f in self.parts())
        return s1, s2

    def check(self):
        """Refuses numbers that make no rotor, naming the field (the user's command line)."""
        problems = []

        def need(ok, field, what):
            if not ok:
                problems.append(f"{field} = {getattr(self, field)!r}: expected {what}")

        need(self.topology in TOPOLOGIES, "topology", " or ".join(TOPOLOGIES))
        need(self.excitation in EXCITATIONS, "excitation", " or ".join(EXCITATIONS))
        need(self.contact_duration >= 0.0, "contact_duration", "a time >= 0 [s] (0: the topology's)")
        need(self.blade_model in ("rigid", "beam"), "blade_model", "rigid or beam")
        need(self.pitch in ("locked", "link"), "pitch", "locked or link")
        need(self.processes in ("blade", "rotor"), "processes", "blade or rotor")
        need(2 <= self.blades <= 12, "blades", "2 to 12 blades")
        need(self.topology != "teetering" or self.blades == 2, "blades", "2 for a teetering rotor")
        need(0.5 <= self.radius <= 30, "radius", "0.5 to 30 m")
        need(0 < self.chord < 0.3 * self.radius, "chord", "between 0 and 0.3 R")
        need(0 < self.flap_offset < 0.3 * self.radius, "flap_offset", "between 0 and 0.3 R")
        need(self.lag_offset <= self.flap_offset, "lag_offset", "at most flap_offset (lag hinge inboard), < 0 for none")
        need(self.droop < 0, "droop", "a negative angle (the droop stop below the blade)")
        need(self.antiflap > 0, "antiflap", "a positive angle")
        need(self.node_mass > 0, "node_mass", "a positive mass [kg]")
        need(self.regularization >= 0, "regularization", ">= 0 [m/N] (0: a rigid tie)")
        need(0 <= self.restitution <= 1, "restitution", "in [0, 1]")
        need(self.omega >= 0, "omega", ">= 0 rad/s")
        need(self.mass_per_length > 0, "mass_per_length", "> 0 kg/m")
        need(self.end_time > 0 and self.step > 0, "end_time", "> 0 s (and step > 0)")
        need(self.topology != "hingeless" or self.blade_model == "beam", "blade_model", "beam for a hingeless rotor")
        if self.sections_csv:
            try:
                pts = self.table()
                ok = len(pts) >= 1 and all(m > 0 for _, m in pts)
            except (OSError, KeyError, ValueError) as e:
                ok, pts = False, str(e)
            need(ok, "sections_csv", "a readable CSV with columns s and mass (BeamStation's names), masses > 0")
        return problems


def _log_uniform(rng, lo, hi):
    return math.exp(rng.uniform(math.log(lo), math.log(hi)))


def twin_contact_duration(topology):
    """The twin's stop contact time when none is given. A flap or teeter stop (an elastomer on a
    hinge) lasts ~20 ms. A hingeless blade's pad is a structural stop under the bending and
    centrifugal load of a blade at speed: at 20 ms (K ~ 0.25 m_blade (3.21/T)^2.5) the twin's pad
    sank 2.8 mm into its droop stop at rest (seed 311) and 24 mm past a 16 mm anti-flap gap at
    full speed (seed 380), where the co-simulated stop holds within the tie's stretch; 5 ms (a law
    32 times stiffer, a tenth of the compression) is a stop that holds the blade."""
    return 0.005 if topology == "hingeless" else 0.02


def draw(seed, topology=None):
    """One rotor drawn from physical ranges, seeded: draw(s) is the same rotor on every machine.
    The ranges are those of helicopter and model rotors (radius 1.5–8 m, tip speeds 150–220 m/s,
    Lock numbers ~4–12, flap frequencies of hingeless blades 1.05–1.2/rev); the stops' and the
    coupling's numbers span what the issue asks (node masses 0.05–10 kg, rigid or regularised
    ties, restitution 0–0.8, one contact process per blade or one for the rotor)."""
    rng = random.Random(seed)
    r = Rotor()
    r.name = f"rotor_{seed}"
    r.topology = topology or TOPOLOGIES[seed % 3]
    r.radius = rng.uniform(1.5, 8.0) if r.topology != "teetering" else rng.uniform(3.0, 7.5)
    r.blades = (
        2 if r.topology == "teetering" else rng.randint(2, 7) if r.topology == "articulated" else rng.randint(3, 5)
    )
    r.chord = r.radius / rng.uniform(12, 20)
    r.blade_model = "beam" if r.topology == "hingeless" else rng.choice(("rigid", "beam"))
    r.mass_per_length = r.radius * rng.uniform(0.8, 1.5)
    r.omega = rng.uniform(150, 220) / r.radius
    span = r.radius
    # Flap stiffness from a non-rotating first cantilever frequency (3.516 √(EI / m L⁴)).
    f1 = rng.uniform(4, 10) if r.topology != "hingeless" else rng.uniform(0.25, 0.45) * r.omega
    r.ei_flap = (f1 / 3.516) ** 2 * r.mass_per_length * span**4
    r.ei_lag = r.ei_flap * rng.uniform(8, 25)
    r.gj = r.ei_flap * rng.uniform(0.8, 3)
    # Axial over flapwise stiffness ~ 8/t² of a thin-walled section of thickness t = 0.12 c.
    r.ea = r.ei_flap * rng.uniform(400, 800) / r.chord**2
    r.root_fraction = rng.uniform(0.05, 0.25)
    r.root_mass_factor = rng.uniform(1.0, 3.0)
    r.root_stiffness_factor = rng.uniform(1.0, 4.0)
    r.tip_mass_factor = rng.choice((1.0, 1.0, rng.uniform(1.5, 3.0)))
    # Coarse meshes too (2 linear elements, 2 quadratic): blades of 2 and of 4 linear elements
    # spinning with a tip weight diverged in flap in both stop models (seeds 6 and 300 of the first
    # draws, at 24 and 38.6 rad/s; in vacuum, with 2 elements both reached ±38°, and seed 300 with
    # 4 ended with exit 3 at ±19°), and blades of 3 quadratic elements in lag (seed 589). The
    # beam's axial strain, measured along the interpolated director, let the blade stretch at no
    # cost under its tension (docs/design.md, "Beam blades"); measured along the reference line,
    # the same blades stay on their stops. Until that fix the generator drew at least 8 linear
    # elements.
    r.nodes_per_element = rng.choice((2, 3))
    r.elements = rng.randint(2, 12) if r.nodes_per_element == 2 else rng.randint(2, 5)
    r.retardation_time = _log_uniform(rng, 5e-5, 1e-3)
    r.flap_offset = rng.uniform(0.02, 0.06) * r.radius
    r.lag_offset = rng.choice((r.flap_offset, r.flap_offset - rng.uniform(0.005, 0.03) * r.radius, -1.0))
    blade_mass = r.mass_per_length * r.radius
    r.lag_damping = rng.uniform(0.02, 0.1) * blade_mass * r.radius**2 * r.omega * 0.1
    r.lag_stop = math.radians(rng.uniform(10, 20))
    r.pitch = rng.choice(("locked", "link"))
    r.undersling = rng.uniform(0.01, 0.03) * r.radius
    r.precone = math.radians(rng.uniform(1.5, 3.5))
    r.pad_arm = rng.uniform(0.015, 0.03) * r.radius
    r.root_radius = rng.uniform(0.04, 0.1) * r.radius
    if r.topology == "teetering":
        r.droop, r.antiflap = -math.radians(rng.uniform(6, 12)), 0.0
        r.antiflap = -r.droop
    else:
        r.droop = -math.radians(rng.uniform(2, 8))
        r.antiflap = math.radians(rng.uniform(3, 12))
    r.hingeless_gap_up = rng.uniform(0.01, 0.04) * r.radius
    r.node_mass = _log_uniform(rng, 0.05, 10.0)
    # Regularised ties only: a stop pad's body is hinged (or a beam's node), and a rigid tie on it
    # closes a loop (refused: singular constraints) or cannot pass an impact into a beam (refused).
    r.regularization = _log_uniform(rng, 1e-9, 2e-8)
    r.processes = rng.choice(("blade", "rotor"))
    r.restitution = round(rng.uniform(0.0, 0.8), 3)
    r.collective = math.radians(rng.uniform(4, 12))
    r.twist = -math.radians(rng.uniform(0, 12))
    r.excitation = rng.choice(EXCITATIONS)
    r.hub_mass = 10 + 5 * r.blades
    if r.excitation == "gust":
        r.idle_fraction = rng.choice((0.0, 0.0, rng.uniform(0.05, 0.3)))
        r.gust_azimuth = rng.uniform(0, 2 * math.pi)
        r.gust_upwash = rng.uniform(0.0, 0.5)
        r.gust_front_speed = rng.uniform(20, 30)
        r.gust_length = rng.uniform(30, 60)
        r.gust_peak = min(45.0, liftoff_speed(r) * rng.uniform(1.2, 2.2))
        r.end_time = round((2 * r.radius + 6 + r.gust_length) / r.gust_front_speed + 0.5, 1)
        r.settle = r.idle_fraction == 0 and rng.random() < 0.4
    else:
        r.wind = rng.uniform(5, 20)
        r.wind_azimuth = rng.uniform(0, 2 * math.pi)
        r.ramp_time = rng.uniform(2, 3)
        r.end_time = round(r.ramp_time + 0.8, 1)
    return r


def liftoff_speed(r):
    """The gust speed whose air load on a still blade balances its weight about the hinge: the
    normal force of a flat section at the gust's angle to the chord (≈ 2 sin α, at least the
    collective's lift), over the span, against the blade's weight moment."""
    gust_angle = math.atan2(r.gust_upwash, math.sqrt(max(1e-9, 1 - r.gust_upwash**2)))
    cn = max(
        0.3, 2 * math.sin(abs(r.collective + r.twist / 2 + gust_angle)), 2 * math.pi * math.sin(r.collective) * 0.5
    )
    # Horizontal gusts lift blades that lie across them only: |sin| of the blade's azimuth, ~2/π on average.
    return math.sqrt(r.mass_per_length * 9.81 / (0.5 * 1.225 * r.chord * min(cn, 1.2) * 0.64))
