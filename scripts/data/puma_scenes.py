#!/usr/bin/env python3
"""Writes the SA330 Puma rotor-sailing scenes of issue 16 (docs/reference/puma.md) as
scenario files with one blade written once (a `patterns` entry placed at four azimuths).
Usage: puma_scenes.py engage_continuous > scenarios/puma/engage_disengage_continuous.pbtxt
       puma_scenes.py gust_continuous   > scenarios/puma/gust_continuous.pbtxt
       puma_scenes.py engage_disengage  > scenarios/puma/engage_disengage.pbtxt  (co-simulated)
       puma_scenes.py gust              > scenarios/puma/gust.pbtxt              (co-simulated)
       puma_scenes.py engage_mbdyn      > scenarios/puma/engage_disengage_mbdyn.pbtxt
         (the continuous engagement modelled as MBDyn's model of the same rotor, docs/reference/mbdyn-puma.md)
       puma_scenes.py ship_engage_continuous > scenarios/puma/ship_engage_continuous.pbtxt
       puma_scenes.py ship_engage            > scenarios/puma/ship_engage.pbtxt  (co-simulated)
         (the engagement on a frigate's moving deck in its airwake, with the operating-limits envelope)
"""
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = sys.argv[1] if len(sys.argv) > 1 else "engage_continuous"
GUST = SCENE.startswith("gust")
SHIP = SCENE.startswith("ship")
# The continuous stops' onset-speed floor on the deck (law.speed_threshold, rad/s): the deck's
# angular-rate amplitude (roll 5° over 10 s: 0.055 rad/s; pitch 3° over 7 s: 0.047 rad/s).
SHIP_THRESHOLD = " speed_threshold: 0.05" if SHIP else ""
# MBDyn's model of the same rotor (docs/reference/mbdyn-puma.md): the continuous engagement with
# its Ω100, no lag stops, a rigid pitch bearing, its inflow correction and its airfoil's slope.
MBDYN = SCENE == "engage_mbdyn"
COSIM = not (SCENE.endswith("_continuous") or MBDYN)
OMEGA = 28.27 if MBDYN else 28.0
DROOP = -10.0 * math.pi / 180  # the droop stop; blades start on it
E_LAG, E_FLAP, R_PITCH, R = 0.269, 0.289, 0.432, 7.49
DEG = 57.29577951308232
# The contact node's mass: a point of the cuff (its stop pad), taken from the cuff's 7.35 kg in the
# co-simulated scenes so that the blade weighs the same in both models (see the file's comments).
NODE_MASS = 0.1
LAG_STOP = 15.0 * math.pi / 180  # lead and lag stops (a choice: the data have none; see the file's comments)
STATIONS = subprocess.run([os.path.join(HERE, "puma_blade_stations.py"), "--clockwise", "8"], check=True,
                          capture_output=True, text=True).stdout.rstrip()


def v(x):
    return "[" + ", ".join(f"{c:.12g}" for c in x) + "]"


def drooped(r):
    """A point of blade 1's axis at radius r (flat), turned by the droop about the flap hinge."""
    return (E_FLAP + (r - E_FLAP) * math.cos(DROOP), 0.0, (r - E_FLAP) * math.sin(DROOP))


span = (math.cos(DROOP), 0.0, math.sin(DROOP))
turned = (0.0, -DROOP, 0.0)  # rotation vector of the droop: β about −y
horn = (E_FLAP, -0.181, 0.0)  # on the flap hinge's axis: flapping does not pitch the blade
swash = (horn[0], horn[1], horn[2] - 0.3)
# Co-simulation: a contact node tied 0.05 m below the blade axis at the pitch bearing (on the
# pitch fitting), and two planes through the flap hinge's axis, attached to the hub, that the node
# meets when the flap angle reaches ∓10°: a point turning about −y by β moves with (−d_z, 0, d_x).
def node_offset(beta):
    """The node relative to the flap hinge's axis (x, z) at flap angle beta."""
    x0, z0 = R_PITCH - E_FLAP, -0.05
    return (x0 * math.cos(beta) - z0 * math.sin(beta), x0 * math.sin(beta) + z0 * math.cos(beta))


node_x, node_z = node_offset(DROOP)
node = (E_FLAP + node_x, 0.0, node_z)
droop_normal = (-node_z, 0.0, node_x)
up_x, up_z = node_offset(-DROOP)
antiflap_normal = (up_z, 0.0, -up_x)
# The ship scenes start the engagement at 5 s, once the deck's motion and the wind have grown in.
SHIFT = 5 if SCENE.startswith("ship") else 0
hub_drive = ("constant: 0" if GUST else
             f"sum {{ terms {{ cosine_ramp {{ final_value: {-OMEGA:g} ramp_time: 20{f' start_time: {SHIFT}' if SHIFT else ''} }} }}\n"
             f"                                               terms {{ cosine_ramp {{ final_value: {OMEGA:g} ramp_time: 20 start_time: {30 + SHIFT} }} }} }}")
if COSIM:
    STOPS = f"""      contact_nodes {{ name: "blade{{k}}_stop_node" mass: {NODE_MASS} position: {v(node)}
                      contacts {{ obstacle: "blade{{k}}_droop" restitution: 0.8 }} contacts {{ obstacle: "blade{{k}}_antiflap" restitution: 0.8 }} }}
      obstacles {{ name: "blade{{k}}_droop" point: [{E_FLAP}, 0, 0] normal: {v(droop_normal)} attached_to_body: "hub" }}
      obstacles {{ name: "blade{{k}}_antiflap" point: [{E_FLAP}, 0, 0] normal: {v(antiflap_normal)} attached_to_body: "hub" }}"""
    STOP_PROBES = """      probes { name: "blade{k}_droop_impulse" quantity: IMPULSE entity: "blade{k}_stop_node/blade{k}_droop" }
      probes { name: "blade{k}_antiflap_impulse" quantity: IMPULSE entity: "blade{k}_stop_node/blade{k}_antiflap" }"""
    COUPLING = """    coupling {
      processes { name: "stops{k}" contact_nodes: ["blade{k}_stop_node"] }
      interface_nodes { contact_node: "blade{k}_stop_node" body: "blade{k}_pitch" point: [0, 0, -0.05] regularization: 5e-9 }
    }
"""
else:
    STOPS = f"""      forces {{ name: "blade{{k}}_stops" joint_stop {{ joint: "blade{{k}}_flap_hinge" lower: {DROOP:.12g} upper: {-DROOP:.12g}
               law {{ stiffness: 1e9 exponent: 1.5 restitution: 0.8 effective_restitution: true{SHIP_THRESHOLD} }} }} }}"""
    STOP_PROBES = """      probes { name: "blade{k}_stop_moment" quantity: CONTACT_FORCE entity: "blade{k}_stops" }"""
    COUPLING = ""
TWIN = "gust_continuous.pbtxt" if GUST else ("ship_engage_continuous.pbtxt" if SHIP else "engage_disengage_continuous.pbtxt")
# `scripts/cosim study compare` (the paper's Fig. 5 / Fig. 7): this scene against its continuous twin.
# `scripts/cosim study timing`: MBDyn's continuous-contact model of the same rotor (peers.md: 2 s
# settling + 50 s at h = 1e-4 s, minimal output, median of three runs on a quiet 2-core machine).
PEER = "" if GUST or SHIP else """
  peer { name: "MBDyn, continuous-contact stops, h = 1e-4 s" wall_time: 787 simulated_time: 52
         source: "docs/reference/peers.md, median of 715, 787, 830 s on a quiet 2-core machine" }"""
ENVELOPE = """
  # `scripts/cosim study envelope`: the blade-sailing envelope of the still rotor over gust peak
  # × the direction the gust travels (degrees from +x, counter-clockwise; 90° is the paper's,
  # along +y), the front starting 32.49 m upwind of the hub in every direction (it reaches the
  # disk at 1 s). Choices: 7 s runs (the gust has passed the disk by 5.6 s), measured from
  # 0.9 s (the blades start straight and sag 0.46 m at the tip in the first 0.4 s: a start-up,
  # not the gust's); a clearance plane 2 m below the hub (an illustration of a cabin roof or
  # tail boom: the data have no fuselage).
  envelope {
    axes { name: "gust peak" unit: "m/s" values: [15, 25, 35] set: "model.air.gusts[0].profile.cosine_pulse.peak={v}" }
    axes { name: "gust direction" unit: "deg" values: [0, 45, 90, 135, 180, 225, 270, 315]
           set: "model.air.gusts[0].direction=[{cos(radians(v))}, {sin(radians(v))}, 0]"
           set: "model.air.gusts[0].front_direction=[{cos(radians(v))}, {sin(radians(v))}, 0]"
           set: "model.air.gusts[0].front_origin=[{-32.49 * cos(radians(v))}, {-32.49 * sin(radians(v))}, 0]" }
    tip_probes: ["blade1_tip_z", "blade2_tip_z", "blade3_tip_z", "blade4_tip_z"]
    clearance_height: -2
    impulse_probes: ["blade1_droop_impulse", "blade1_antiflap_impulse", "blade2_droop_impulse", "blade2_antiflap_impulse",
                     "blade3_droop_impulse", "blade3_antiflap_impulse", "blade4_droop_impulse", "blade4_antiflap_impulse"]
    set: "numerics.end_time=7"
    from_time: 0.9
  }""" if GUST else ""
# The ship's operating-limits envelope (issue 35): wind speed in knots (radial) × relative wind
# direction (around, clockwise from the bow as in a ship–helicopter operating-limits diagram).
KNOT = 0.514444
SHIP_KNOTS, SHIP_DIRECTION, K_WINDWARD, K_LEEWARD = 30, 30, 0.27, -0.1
STOP_LOAD_PROBES = ('''    impulse_probes: ["blade1_droop_impulse", "blade1_antiflap_impulse", "blade2_droop_impulse", "blade2_antiflap_impulse",
                     "blade3_droop_impulse", "blade3_antiflap_impulse", "blade4_droop_impulse", "blade4_antiflap_impulse"]'''
                    if COSIM else
                    '''    force_probes: ["blade1_stop_moment", "blade2_stop_moment", "blade3_stop_moment", "blade4_stop_moment"]''')
SHIP_ENVELOPE = f"""
  # `scripts/cosim study envelope`: the engagement and disengagement over wind speed (5 to 45 kt)
  # × relative wind direction (every 30°), the deck moving as below in every run. Measured per
  # point: each tip's height above the deck plane (probes in the deck's frame), its lowest and
  # when, the clearance above the tail-boom plane 2 m below the hub (8.4 m in the deck's frame;
  # negative: a strike), the stops' peak load and impacts. Unsafe where the clearance is below
  # 0.3 m (hatched: the tips rest ~0.5 m above that plane, drooped and sagged, so 0.3 m is a
  # tip dipping ~0.2 m below its resting height; a choice), or where a run failed.
  envelope {{
    axes {{ name: "wind speed" unit: "kt" values: [5, 10, 15, 20, 25, 30, 35, 40, 45]
           set: "model.air.airwake.speed={{v * {KNOT}}}" }}
    axes {{ name: "relative wind direction" unit: "deg" values: [0, 30, 60, 90, 120, 150, 180, 210, 240, 270, 300, 330]
           set: "model.air.airwake.direction={{v}}" compass: true }}
    tip_probes: ["blade1_tip_deck", "blade2_tip_deck", "blade3_tip_deck", "blade4_tip_deck"]
    clearance_height: 8.4
    unsafe_clearance: 0.3
{STOP_LOAD_PROBES}
  }}""" if SHIP else ""
# The engagement's work-precision study (issue 31): each model against its own converged run —
# the co-simulated one at h = 0.25 ms (a quarter of the scene's step: a finer co-simulated
# reference costs hours), the continuous one at 0.125 ms — with the measures the issue names:
# blade 1's flap angle over the run, its stop contacts' start and end times (lift-off, re-contact)
# and the peak root shear and flapwise moment in each contact.
PRECISION = '''
  # `scripts/cosim study work-precision`: error of each measure against wall time (issue 31).
  events { history_probes: ["blade1_flap"] peak_probes: ["blade1_root_shear_z", "blade1_root_flap_moment"] }
  methods { name: "continuous, fixed h" scenario: "engage_disengage_continuous.pbtxt" sweep_values: [4e-3, 2e-3, 1e-3, 5e-4]
            contact_probes: ["blade1_stop_moment"] reference: { name: "continuous, h = 0.125 ms"
            scenario: "engage_disengage_continuous.pbtxt" set: ["numerics.step=1.25e-4", "output.every=16"]
            contact_probes: ["blade1_stop_moment"] } }
  methods { name: "continuous, fixed h, matrix not co-rotated" scenario: "engage_disengage_continuous.pbtxt"
            set: ["numerics.smooth.jacobian_frame=\\"\\""] sweep_values: [2e-3, 1e-3]
            contact_probes: ["blade1_stop_moment"] reference: { name: "continuous, h = 0.125 ms"
            scenario: "engage_disengage_continuous.pbtxt" set: ["numerics.step=1.25e-4", "output.every=16"]
            contact_probes: ["blade1_stop_moment"] } }
  methods { name: "continuous, adaptive" scenario: "engage_disengage_continuous.pbtxt"
            sweep_field: "numerics.adaptive.relative" sweep_values: [1e-4, 1e-5, 1e-6]
            contact_probes: ["blade1_stop_moment"] reference: { name: "continuous, h = 0.125 ms"
            scenario: "engage_disengage_continuous.pbtxt" set: ["numerics.step=1.25e-4", "output.every=16"]
            contact_probes: ["blade1_stop_moment"] } }
  methods { name: "co-simulated, fixed h" sweep_values: [2e-3, 1e-3, 5e-4]
            contact_probes: ["blade1_droop_impulse", "blade1_antiflap_impulse"]
            reference { name: "co-simulated, h = 0.25 ms" set: ["numerics.step=2.5e-4", "output.every=8"]
                        contact_probes: ["blade1_droop_impulse", "blade1_antiflap_impulse"] } }''' if COSIM and not GUST and not SHIP else ""
# MBDyn's histories beside this variant's and the continuous scene's, with the measures of
# agreement (issue 33): lift-off and re-contact within 50 ms, coning within 0.05°, lag within 1°;
# and the variant with each of MBDyn's choices undone in turn, to size each one's share.
MBDYN_STUDY = """# `scripts/cosim study compare`: MBDyn's blade 1 against this variant's (settled start) and the
# continuous scene's, and this variant with MBDyn's inflow correction, lift slope, Ω100 or settled
# start undone in turn (and without compressibility, to size the polar's Mach dependence).
study {
  probes: ["blade1_flap", "blade1_lag"]
  compare { name: "MBDyn" history_file: "../../docs/reference/data/mbdyn_puma_engagement_rootpitch0.csv" }
  compare { name: "MBDyn-equivalent" settle_statically: true }
  compare { name: "continuous scene" scenario: "engage_disengage_continuous.pbtxt" }
  compare { name: "equivalent, κ = 1" settle_statically: true set: ["model.air.rotors[0].induced_velocity_factor=1"] }
  compare { name: "equivalent, lift slope 5.7296" settle_statically: true
            set: ["model.air.airfoils[0].builtin_lift_slope=5.7296"] }
  compare { name: "equivalent, Ω100 = 28" settle_statically: true
            set: ["model.joints[0].drive.function.sum.terms[0].cosine_ramp.final_value=-28",
                  "model.joints[0].drive.function.sum.terms[1].cosine_ramp.final_value=28"] }
  compare { name: "equivalent, straight start" }
  compare { name: "equivalent, incompressible" settle_statically: true set: ["model.air.speed_of_sound=1e9"] }
  measures { name: "lift-off from the droop stop [s]" probe: "blade1_flap" kind: LAST_NEAR_START to: 20 tolerance: 0.1
             agreement: 0.05 }
  measures { name: "re-contact [s]" probe: "blade1_flap" kind: FIRST_NEAR_START from: 30 tolerance: 0.1 agreement: 0.05 }
  measures { name: "coning, mean flap 22–28 s [deg]" probe: "blade1_flap" kind: MEAN from: 22 to: 28 agreement: 0.05 }
  measures { name: "peak lag [deg]" probe: "blade1_lag" kind: MAX agreement: 1 }
  measures { name: "peak lead [deg]" probe: "blade1_lag" kind: MIN agreement: 1 }
}"""
STUDY = f'''# `scripts/cosim study compare` draws blade 1 of both models on the same axes (the paper's
# Fig. {7 if GUST else 5}) and tables their differences and each stop contact.
study {{
  probes: ["blade1_flap", "blade1_lag", "blade1_root_shear_z", "blade1_root_flap_moment", "blade1_tip_z"]
  compare {{ name: "co-simulated" contact_probes: ["blade1_droop_impulse", "blade1_antiflap_impulse"] }}
  compare {{ name: "continuous" scenario: "{TWIN}" contact_probes: ["blade1_stop_moment"] }}{PEER}{ENVELOPE}{PRECISION}{SHIP_ENVELOPE}
}}''' if COSIM else (MBDYN_STUDY if MBDYN else (f"""# `scripts/cosim study envelope`: the operating-limits envelope of this continuous twin.
study {{{SHIP_ENVELOPE}
}}""" if SHIP else ""))
# The coupling's defaults (interface Jacobians, tolerances 1e-9 m and 1e-6, no step accepted
# unconverged) but for the restart at a new contact (see the file's comments).
COUPLING_ITERATION = "coupling { iteration { restart_at_impact: false } }"
SHIP_NUMERICS = """# The ship scenes take the default (projected) constraint form, not the index-3 form the
# fixed-hub scenes' notes below describe: with the deck moving, the index-3 form's reused matrix
# became singular at stop landings (29 of the continuous envelope's 108 points at 20 kt and
# above, e.g. 30 kt from 90° at 11.5 s, blade 2 landing on its droop stop while on its lag stop);
# fresh matrices every iteration (4× slower) or h = 1 ms ran the case tried, and the projected
# form runs all of them.
# The continuous stops' laws take speed_threshold 0.05 rad/s, the deck's angular-rate amplitude
# (roll 0.055, pitch 0.047 rad/s), instead of the default 1e-3: the law's damping is
# K δⁿ χ δ̇/δ̇⁻ (Eq. (8)) with δ̇⁻ the onset speed, at least the threshold, and a blade that the
# deck lays onto its stop at a few mrad/s gets a damping ~50 times that of a real landing, which
# pulls the force to zero (the law's clamp) as soon as the deck lifts the blade at δ̇⁻/χ. That
# switch, at 10⁶ N m s/rad, sent Newton to a spurious root (observed: 35 kt from 90°, blade 3 on
# its droop and lag stops thrown 2° up in one 2 ms step at 13.28 s, the next step's projection
# diverging), and stopped 7 of the 108 envelope points at h = 2 ms with the default. Slower
# landings get the dissipation of one at 0.05 rad/s (a tip speed of 0.37 m/s).
""" if SHIP else ""
DECK = """  moving_bases {
    name: "deck" point: [0, 0, -10.4]
    heave { harmonic { amplitude: 1 period: 8 phase: 2.1 ramp_time: 5 } }
    roll { harmonic { amplitude: 0.0872664626 period: 10 ramp_time: 5 } }
    pitch { harmonic { amplitude: 0.0523598776 period: 7 phase: 1.3 ramp_time: 5 } }
  }
""" if SHIP else ""
TIP_DECK = """
      probes { name: "blade{k}_tip_deck" quantity: POSITION entity: "blade{k}.n10" frame: "deck" component: Z }""" if SHIP else ""
CUFF_MASS = 7.3512 - (NODE_MASS if COSIM else 0.0)
PITCH_LINK_BODY = "" if MBDYN else f"""      bodies {{ name: "blade{{k}}_pitch_link" mass: 0.5 inertia: [0.00375, 0.00375, 1e-4] position: {v((horn[0], horn[1], horn[2] - 0.15))} }}
"""
PITCH_LINK_JOINTS = "" if MBDYN else f"""      joints {{ name: "blade{{k}}_horn" type: SPHERICAL body1: "blade{{k}}_pitch" body2: "blade{{k}}_pitch_link" point: {v(horn)} }}
      joints {{ name: "blade{{k}}_swashplate" type: UNIVERSAL body1: "hub" body2: "blade{{k}}_pitch_link" point: {v(swash)} axis: [1, 0, 0] axis2: [0, 1, 0] }}
"""
PITCH_LOCK = " locked: true" if MBDYN else ""
LAG_STOPS = "" if MBDYN else f"""      forces {{ name: "blade{{k}}_lag_stops" joint_stop {{ joint: "blade{{k}}_lag_hinge" lower: {-LAG_STOP:.12g} upper: {LAG_STOP:.12g}
               law {{ stiffness: 1e8 exponent: 1.5 restitution: 0.5 effective_restitution: true{SHIP_THRESHOLD} }} }} }}
"""
AIRFOIL = "naca0012_mbdyn_slope" if MBDYN else "naca0012"
# MBDyn's hover correction K_H = 1.1 scales its hover inflow by K_H² (docs/reference/mbdyn-puma.md).
INFLOW_FACTOR = " induced_velocity_factor: 1.21" if MBDYN else ""
stops_kind = "co-simulated stops (four contact processes)" if COSIM else "continuous-contact stops"
title = ("still rotor in a gust (Fig. 7), " if GUST else
         "engagement and disengagement on a frigate's moving deck in its airwake, " if SHIP else
         "engagement and disengagement (Fig. 5), ") + stops_kind
if MBDYN:
    title = "engagement and disengagement, continuous-contact stops, modelled as MBDyn's model of the same rotor"
HEADER = (f"""# SA330 research Puma, {'' if SHIP else "the rotor-sailing paper's "}{title}: four articulated
# elastic blades, one written once (`patterns`), {"co-simulated: each blade has a contact node against" if COSIM else "monolithic: the stops are Hunt–Crossley laws on"}
# {"a droop and an anti-flap plane on the hub, in its own contact process (Moreau–Jean, Lemke)" if COSIM else "the flap hinges"}. Generated by scripts/data/puma_scenes.py {SCENE}; the blade tables by
# scripts/data/puma_blade_stations.py. Data: docs/reference/puma.md, aero.md.
# Choices where the data leave gaps:
# - hub 50 kg, [5, 5, 10] kg m²; driven (speed) about +z, the rotor turning clockwise seen from above;
# - lead and lag stops at ±15° on the lag hinge (Hunt–Crossley, K = 1e8 N m/rad^1.5, e = 0.5,
#   an elastomer-lined stop), in both the continuous and the co-simulated scenes: the data have a
#   lag damper and no lag spring, and during the spin-up the hub's angular acceleration (up to
#   2.2 rad/s²) needs ~3 kN m at each lag hinge while the centrifugal lag stiffness is only
#   Ω² e S_ζ ≈ 67 Ω² N m/rad — without stops the blades lag past 60° in the first 8 s, where the
#   pitch link (rigid, its lower end fixed) pulls the pitch ~−0.3 ζ² nose down, the extra drag
#   lags them further, and they wind round the lag hinge (observed: 370° at 11 s). Real
#   articulated hubs have such stops; their Puma values are not in the data;
# - lag link (0.269 → 0.289 m): 0.526 kg at 0.2845 m; cuff (flap hinge → pitch bearing, does not
#   pitch): """ + (f"7.25 kg at 0.3605 m (and the 0.1 kg contact node)" if COSIM else "7.35 kg at 0.3605 m") + """; pitch fitting at the pitch bearing (the beam's clamp, carries the
#   horn): 1 kg — together the tables' 8.35 kg over 0.289–0.432 m;
# - pitch horn at (0.289, −0.181) m in blade coordinates (radial, counter-clockwise tangent): on
#   the flap hinge's axis, so flapping does not change pitch; a rigid pitch link 0.3 m long
#   (0.5 kg) straight down to the swashplate's rotating ring, here a point of the hub (zero
#   collective and cyclic, swashplate fixed): spherical at the horn, universal at the ring;
# - beam from the pitch bearing to the tip, 5 quadratic elements (the MBDyn model's), GA = EA,
#   structural damping 1e-4 s; chord towards the leading edge (d3 down, the tables' twist negated);
# - stops: droop −10°, anti-flap +10° on the flap hinge, """ + ("""Newton restitution 0.8 for a contact node of 0.1 kg (a point of
#   the cuff, its stop pad: its mass taken from the cuff's, which keeps 7.25 kg, so the blade
#   weighs what the continuous scene's does; the data give no pad mass). The coupling takes the
#   light node in one exchange a step with interface Jacobians (docs/protocol.md; a black-box
#   relaxation needed a 7 kg node: the tie's gain h² k/m is 1000 for 0.1 kg at h = 1 ms); the node's
#   tied (Tikhonov compliance 5e-9 m/N, puma.md's figure read per metre) 0.05 m below the blade
#   axis at the pitch bearing, on the pitch fitting; the planes pass through the flap hinge's axis
#   and through the node's place at ∓10°, attached to the hub (as the issue and the paper put
#   them): a blade lagged 15° on its lag stop meets its droop plane at a flap angle of −9.1°, not
#   −10° as the continuous scene's hinge-angle law (observed in the full engagement). Planes on
#   the lag link would act at −10° whatever the lag, but made the gust's coupled step at the
#   lift-off diverge (the plane's motion is a second coupling path): not yet;""" if COSIM else """Hunt–Crossley/Flores with n = 3/2,
#   rebound e = 0.8 (the law's e solved for it), K = 1e9 N m/rad^1.5 — the paper's 1e9 "N/m^1.5"
#   read with a 1 m lever (moment = K δ^1.5, δ in rad);""") + f"""
# - start: at rest, blades drawn drooped 10° onto their droop stops (flap hinge at −10°: the
#   joints' initial_coordinate), gravity from t = 0 (the stop's static sag is ~1e-5 rad);
# - air: strip theory on the beams from 2.08 m, NACA 0012 built in, uniform momentum inflow
#   (zero below a 10 m/s tip speed); sea-level air (1.225 kg/m³, 340 m/s), still{' until the gust' if GUST else ''};
# - probes: angles in degrees; pitch bearing angle too (deg);
#   root shear and flapwise moment at r = 0.5 m (the first section
#   outboard of the pitch bearing), in the beam's section frame (d3, the flapwise axis, points
#   down: an upward shear on the outboard part reads negative); the stops' contact moment [N m].""")
MBDYN_HEADER = f"""# SA330 research Puma, engagement and disengagement with continuous-contact stops, modelled as
# MBDyn's model of the same rotor (docs/reference/mbdyn-puma.md, whose histories this scene's
# `scripts/cosim study compare` draws beside its own). Generated by scripts/data/puma_scenes.py
# {SCENE}: the continuous engagement (engage_disengage_continuous.pbtxt; its comments give the
# blade, hub, stops and probes) with MBDyn's choices where the two models differ:
# - Ω100 = {OMEGA} rad/s (the scene: 28.0), the same cosine ramps;
# - no lead and lag stops (the blades swing to ~49° lag in the run-up and ~−72° lead at the
#   end, against the 7000 N m s/rad damper alone);
# - a rigid pitch bearing (locked) and no pitch link: lag does not pitch the blade;
# - inflow: uniform momentum with MBDyn's hover correction K_H = 1.1, which its uniform rotor
#   applies as ν = K_H² ν_momentum in hover (induced_velocity_factor 1.21); MBDyn's delay 0.9
#   (a weight per step at h = 1e-4 s: a first-order lag of ~0.9 ms) is left out, as is its
#   one-step lag (the scene's inflow is the last accepted state's: 2 ms);
# - airfoil: the built-in NACA 0012 fit at MBDyn's C81 deck's low-Mach lift slope 6.04/rad (the
#   fit's own 5.7296; stall and post-stall the fit's): the deck itself is not in the repository;
# - start: MBDyn settles for 2 s under gravity before t = 0; the study starts this scene from
#   its static equilibrium (settle_statically: a STATIC step, then DYNAMIC from its state).
# Left as the scene has them (their effect named in docs/results.md, "MBDyn on the same rotor"):
# 5 quadratic beam elements with distributed mass (MBDyn: three-node beams, mass lumped at the
# nodes), CGα at h = 2 ms (MBDyn: multistep, ρ∞ = 0.6, h = 1e-4 s)."""
print(MBDYN_HEADER if MBDYN else HEADER)
if SHIP:
    print(f"""# The ship (issue 35; every figure below a stated choice, docs/reference/ship.md for the sources):
# - the rotor on a frigate's flight deck: the hub 4.4 m above the deck (the Puma's rotor-head
#   height on its wheels, a choice); the deck moved by model.moving_bases "deck" (the shaft's
#   body1), its rotations about a point 6 m below the deck on the hub's vertical (a roll and
#   pitch centre near the waterline, a choice): roll 5° amplitude, 10 s period; pitch 3°, 7 s;
#   heave 1 m, 8 s (the amplitudes at the helicopter-operations roll and pitch limits of
#   docs/reference/ship.md; the periods and the heave are choices); each a sine ramped in over
#   the first 5 s (ramp_time), so that the deck is at rest and level when the run starts; the
#   phases 0, 1.3 and 2.1 rad (a choice: the three do not peak together);
# - the airwake: a mean wind of {SHIP_KNOTS} kt (model.air.airwake.speed in m/s) from {SHIP_DIRECTION}° (where
#   the wind comes from, clockwise from the bow: from the starboard bow), its vertical part
#   LINEAR across the disk from an up-wash of {K_WINDWARD} V at the windward edge (ξ = −R) to {K_LEEWARD} V at the
#   leeward edge (+R), R = 7.49 m (0.27 = tan 15°, the low end of docs/reference/ship.md's deck-edge
#   up-flow angles; the leeward down-wash a choice);
#   the airwake does not follow the deck's oscillation (the ship's mean frame);
# - the timeline: the scene starts at rest in still air on a level deck, settled
#   (numerics.smooth.settle: the elastic blades sagged on their droop stops, not released
#   straight); over the first 5 s the deck's motion and the wind grow in (the airwake's
#   ramp_time) with the rotor stopped; the engagement's run-up starts at 5 s, its run-down at
#   35 s (the fixed-hub scene's, 5 s later), and the run ends at 55 s. Not settled in the wind
#   itself: a stopped blade's lag has no stiffness (a damper and ±15° stops only), and the static
#   solve finds no equilibrium from the drawn pose (observed: no convergence in 50 Newton
#   iterations);
# - clearance: probes blade{{k}}_tip_deck give each tip's height in the deck's frame (origin 6 m
#   below the deck): the deck plane is at 6 m, the hub at 10.4 m; the envelope's clearance
#   plane, 2 m below the hub (the tail boom's top, a choice: the data have no fuselage), at 8.4 m.""")
if GUST:
    print("""# - gust: 1 − cos pulse, 100 m long, its front travelling along +y at 25 m/s (4 s at a point,
#   puma.md's choice), reaching the disk's edge at t = 1 s; collective 10° (added to the aero
#   twist; the structure's pitch stays the pitch link's). Peak 35 m/s, chosen so that the scene
#   does what the paper's Fig. 7 shows (its profile, Fig. 6, is only drawn): blade 1 lifted onto
#   its anti-flap stop and back onto its droop stop with elastic bouncing, blade 3 pressed down
#   by the reverse flow, blades 2 and 4 (radial flow) barely moving. Measured on the continuous
#   scene: blade 1 lifts off at 2.36 s, rests on its anti-flap stop from 3.66 to 4.20 s, lands
#   at 4.98 s and bounces on its droop stop until the run ends; blades 2 to 4 stay on their
#   droop stops (within 0.03°). Peaks of 25 m/s (puma.md's first guess) and 30 m/s lift blade 1
#   to −5.6° and +5.0° only.""")
print(f"""name: "puma_{SCENE}"
description: "SA330 Puma rotor, {title}"
model {{
  gravity: [0, 0, -9.81]
{DECK}  bodies {{ name: "hub" mass: 50 inertia: [5, 5, 10] position: [0, 0, 0] }}
  joints {{ name: "shaft" type: REVOLUTE body1: "{'deck' if SHIP else 'ground'}" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]
           drive {{ quantity: ANGULAR_SPEED function {{ {hub_drive} }} }} }}
  air {{""")
if GUST:
    print("""    gusts { front_direction: [0, 1, 0] direction: [0, 1, 0] front_speed: 25 front_origin: [0, -32.49, 0]
            profile { cosine_pulse { peak: 35 duration: 100 } } }""")
if MBDYN:
    print("""    airfoils { name: "naca0012_mbdyn_slope" builtin_lift_slope: 6.04 }""")
if SHIP:
    print(f"""    airwake {{ speed: {SHIP_KNOTS * KNOT:.6g} direction: {SHIP_DIRECTION} form: LINEAR windward: {K_WINDWARD} leeward: {K_LEEWARD} length: {R} ramp_time: 5 }}""")
print(f"""    rotors {{ name: "rotor" hub: "hub" axis: [0, 0, 1] radius: 7.49 inflow: UNIFORM{INFLOW_FACTOR} surfaces: ["blade{{blades}}"] }}
  }}
}}
patterns {{
  name: "blades"
  count: 4
  axis: [0, 0, 1]
  each {{
    model {{
      bodies {{ name: "blade{{k}}_lag" mass: 0.5256 inertia: [0.001, 0.001, 0.001] position: [0.2845, 0, 0] }}
      bodies {{ name: "blade{{k}}_cuff" mass: {CUFF_MASS:.12g} inertia: [0.01, 0.0142, 0.0142] position: {v(drooped(0.3605))} rotation: {v(turned)} }}
      bodies {{ name: "blade{{k}}_pitch" mass: 1 inertia: [0.01, 0.01, 0.01] position: {v(drooped(R_PITCH))} rotation: {v(turned)} }}
{PITCH_LINK_BODY}      joints {{ name: "blade{{k}}_lag_hinge" type: REVOLUTE body1: "hub" body2: "blade{{k}}_lag" point: [{E_LAG}, 0, 0] axis: [0, 0, 1] }}
      joints {{ name: "blade{{k}}_flap_hinge" type: REVOLUTE body1: "blade{{k}}_lag" body2: "blade{{k}}_cuff" point: [{E_FLAP}, 0, 0] axis: [0, -1, 0]
               initial_coordinate: {DROOP:.12g} }}
      joints {{ name: "blade{{k}}_pitch_bearing" type: REVOLUTE body1: "blade{{k}}_cuff" body2: "blade{{k}}_pitch" point: {v(drooped(R_PITCH))} axis: {v(span)}{PITCH_LOCK} }}
{PITCH_LINK_JOINTS}      forces {{ name: "blade{{k}}_lag_damper" joint_spring {{ joint: "blade{{k}}_lag_hinge" stiffness: 0 damping: 7000 }} }}
{LAG_STOPS}{STOPS}
      beams {{
        name: "blade{{k}}" root: {v(drooped(R_PITCH))} axis: {v(span)} chord: [0, -1, 0]
        span_start: {R_PITCH} span_end: {R} elements: 5 nodes_per_element: 3 retardation_time: 1e-4 root_body: "blade{{k}}_pitch"
{STATIONS}
      }}
      air {{
        surfaces {{ name: "blade{{k}}" beam: "blade{{k}}" upper: [0, 0, 1] gauss_points: 3
                   stations {{ s: 2.08 chord: 0.537 twist: {0.174532925199 if GUST else 0} airfoil: "{AIRFOIL}" }}
                   stations {{ s: 7.49 chord: 0.537 twist: {0.174532925199 if GUST else 0} airfoil: "{AIRFOIL}" }} }}
      }}
    }}
{COUPLING}    output {{
      probes {{ name: "blade{{k}}_flap" quantity: JOINT_COORDINATE entity: "blade{{k}}_flap_hinge" scale: {DEG} }}
      probes {{ name: "blade{{k}}_lag" quantity: JOINT_COORDINATE entity: "blade{{k}}_lag_hinge" scale: {DEG} }}
      probes {{ name: "blade{{k}}_pitch" quantity: JOINT_COORDINATE entity: "blade{{k}}_pitch_bearing" scale: {DEG} }}
      probes {{ name: "blade{{k}}_root_shear_z" quantity: SECTION_FORCE entity: "blade{{k}}" station: 0.5 component: Z }}
      probes {{ name: "blade{{k}}_root_flap_moment" quantity: SECTION_MOMENT entity: "blade{{k}}" station: 0.5 component: Y }}
      probes {{ name: "blade{{k}}_tip_z" quantity: POSITION entity: "blade{{k}}.n10" component: Z }}
{STOP_PROBES}{TIP_DECK}
    }}
  }}
}}
{COUPLING_ITERATION if COSIM else ""}
{STUDY}
{SHIP_NUMERICS}# Numerics (choices, measured in docs/results.md, "The Puma scenes"): h = 1 ms{' (2 ms here, below)' if not COSIM and not GUST else ''}, ten times the
# paper's 1e-4 s — the co-simulated impacts need no small step (Moreau–Jean), and the continuous
# law's contact at K = 1e9 lasts ~20 ms on the droop stop; the Newton matrix is reused over up
# to 20 steps (and every coupling iteration) while it contracts the corrections 4× or better.
# {'''The default (projected) constraint form: measured with interface Jacobians and the 0.1 kg
# pads, it runs the gust at h = 1 ms (1.008 exchanges a step, 27 s) and at 2 ms (1.028 a step),
# the engagement at 1 ms (2.04 a step, 273–360 s) and at 2 ms (1.34 a step, 303 s: its Newton
# reuses the matrix less); the CGα paper's index-3 form took the engagement in 1.54 exchanges
# a step (262 s) and the gust at 1 ms in 1.003 (25 s), but lost the lag links' velocity-level
# rigidity at 2 ms (the watchdog at 6.646 s, blade 3 landing). Before the interface Jacobians the
# projected form's position projection diverged when a blade left its stop (the gust at 5.9 s).
# The coupling's defaults (interface Jacobians, a step accepted only converged, resting contacts
# kept in the LCP while pressed) but one: no restart of the smooth model at a new contact
# (restart_at_impact: false). The restart sets the pad's point to its node's velocity by a
# projection in the kinetic-energy metric, which moves the cuff and the pitch fitting but not
# the beam's nodes: the gust's landing at 4.426 s then read 85 kN of root shear for a step
# (2.25 kN without, the continuous twin 2.7 kN); the blade's flap angle is the same within 0.002°.
# Without it the pad's velocity jump reaches the blade through the stiff tie (5e-9 m/N) in a
# few steps.''' + ('' if GUST else '''
# Issue 31: the matrix is reused co-rotated with the hub (jacobian_frame), the peers' compliance
# added to each solve by Woodbury's identity in the factorised axes: whole run 92.9 s against
# 330 s unrotated, 1.001 exchanges a step (5010 factorisations in 50 000 steps); a step whose
# contact processes' answer agrees with its linearising pre-solve is accepted on it (the
# coupling's default; 40 375 of 50 000 steps: every one with the blades off their stops); and
# the engagement takes the index-3 form at h = 1 ms as its continuous twin does (Ωh = 0.028):
# no position projection (1.9 solves a step of ~6): 91 s, 1.001 exchanges a step.''') if COSIM else '''The CGα paper's index-3 form: the hub's Ωh = 0.028 is below the ~0.04 where that form stops
# damping its velocity-constraint mode (docs/design.md, "Spinning bodies").''' + ('' if GUST else '''
# The matrix is reused co-rotated with the hub (jacobian_frame, issue 31): whole run 35.7 s
# against 127.9 s (2519 factorisations instead of 27 972), and closer to a converged run
# (h = 0.125 ms, first 12 s): flap 0.0028° against 0.0081°, root shear 85 N against 473 N,
# flapwise moment 74 against 445 N m (its stricter acceptance of a reused matrix's iterate).
# Not in the gust (the rotor stands still: 38 % slower, the same error).
# h = 2 ms, the matrix reused over up to 40 steps (issue 31; scripts/cosim study work-precision,
# each against h = 0.125 ms): 14.8 s for the 50 s, closer than the unrotated 1 ms run the scene
# had in all four of the study's measures (flap 0.0058° against 0.0081°, contact times exact
# against 2 ms, peak root shear 11.9 against 48.5 N, flapwise moment 0.80 against 13.5 N m);
# at age 20 17.1 s and the same errors; at 1 ms (co-rotated) 31.9 s, flap 0.0028°, shear 36 N.
# (Age 80 ran 14.1 s, flap 0.0061°, but first exposed a Newton test that took non-finite
# multipliers for converged: mended, docs/design.md.) Output every step: rows every 2 ms, as the
# co-simulated twin's.''')}
numerics {{
  end_time: {15 if GUST else 50 + SHIFT}
  step: {'2e-3' if not COSIM and not GUST else '1e-3'}
  smooth {{ {'settle: true ' if SHIP else ''}rho_inf: 0.6 jacobian_max_age: {40 if not COSIM and not GUST else 20}{'' if (COSIM and GUST) or SHIP else ' constraint_form: INDEX3'}{'' if GUST else ' jacobian_frame: "hub"'} }}
}}
output {{
  every: {1 if not COSIM and not GUST else 2}
  probes {{ name: "hub_speed" quantity: JOINT_SPEED entity: "shaft" }}
  probes {{ name: "thrust" quantity: ROTOR_THRUST entity: "rotor" }}
}}""")
